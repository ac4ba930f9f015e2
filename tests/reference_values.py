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


#: Issue 17 ("diverging simulations called stable"): scenes the old measured verdict called stable.
#: The rigid LHifAM (chapter Table 2, K_cr = 7000.756 N/m at B = 0) released from 1 mm at 20000 N/m
#: (2.9 × K_cr), and two cable devices like the issue's (T = 1 ms, 1.7 ms delay, k_c = 147 kN/m) found by
#: a random search for releases at 1.05 × K_cr the old verdict called stable at 5 s ("B", a 787.5 rad/s
#: cable mode with spectral radius 1.0000615) and still at 20 s ("A", 771.8 rad/s, 1.0000364).  Their
#: K_cr comes from optim.stability.margins at test time; the poles are checked against tests/optim/independent.py.
ISSUE17_RIGID = {"mass": 5.4, "damping": 3.5, "sample_time": 0.001}
ISSUE17_CABLES = {
    "B": {"sample_time": 0.001, "delay": 0.0017,
          "cable": {"motor_mass": 0.357, "body_mass": 0.704, "motor_damping": 0.38, "body_damping": 3.45,
                    "stiffness": 147000.0, "damping": 0.027}},
    "A": {"sample_time": 0.001, "delay": 0.0017,
          "cable": {"motor_mass": 0.333, "body_mass": 0.952, "motor_damping": 0.102, "body_damping": 1.22,
                    "stiffness": 147000.0, "damping": 0.222}},
}
