"""Reference values in one place, with their source and tolerance.

``data/seed_cases.json`` is a verbatim copy of the project's shared
``reference/seed_cases.json``: the values the chapter (Díaz, Gil & Hulin,
"Stability Boundary and Transparency for Haptic Rendering") prints, each with
the tolerance it deserves.  Tests read it from here only.
"""

from __future__ import annotations

import json
from pathlib import Path

_DATA = json.loads((Path(__file__).parent / "data" / "seed_cases.json").read_text())

DEVICES: dict = _DATA["devices"]
CASES: dict[str, dict] = {c["id"]: c for c in _DATA["cases"]}


def device_params(spec: str) -> dict:
    """'lhifam/rigid' -> {'mass':..., 'damping':..., 'sample_time':...}; '…/cable' -> {'cable': {...}, ...}."""
    name, model = spec.split("/")
    dev = DEVICES[name]
    out = {"sample_time": dev["sample_time"]}
    if model == "rigid":
        out.update(dev["rigid"])
    else:
        out["cable"] = dict(dev["cable"])
    return out
