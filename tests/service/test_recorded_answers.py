"""Every documented example answers exactly as recorded: refactors (typed outcomes, the layout, the client's own
models) change no public answer.

The examples are the request examples of every operation in /openapi.json (the ones the README and docs/ quote
and Swagger UI offers).  Their answers were recorded on main before the typed-boundaries refactor
(tests/data/recorded_answers.json, written by ``ZWIDTH_RECORD_ANSWERS=1 pytest tests/service/test_recorded_answers.py``)
and are compared with wall-clock timings removed: strings, integers, booleans and nulls exactly, floats to 1e-9
relative (a float that moves further is a changed answer: record again only with the reason in the commit).
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import pytest

RECORD = Path(__file__).resolve().parents[1] / "data" / "recorded_answers.json"
#: wall-clock fields (they differ between any two runs) and run-specific ids
VOLATILE = frozenset({"elapsed_ms", "setup_ms", "solve_ms", "id", "created_at", "started_at", "finished_at",
                      "rate", "eta_s"})
#: operations whose answer depends on the server's state or are figures (checked elsewhere)
SKIP_PREFIXES = ("/v1/studies", "/v1/plots")
FLOAT_RTOL = 1e-9


def _examples(schema: dict) -> list[tuple[str, int, dict]]:
    out = []
    for path, item in sorted(schema["paths"].items()):
        op = item.get("post")
        if not op or "requestBody" not in op or path.startswith(SKIP_PREFIXES):
            continue
        content = op["requestBody"]["content"]["application/json"]
        named = [e["value"] for e in (content.get("examples") or {}).values()]
        ref = content.get("schema", {}).get("$ref", "")
        component = schema["components"]["schemas"].get(ref.rsplit("/", 1)[-1], {}) if ref else {}
        for i, body in enumerate(named + list(component.get("examples") or [])):
            out.append((path, i, body))
    return out


def _strip(value):
    if isinstance(value, dict):
        return {k: _strip(v) for k, v in value.items() if k not in VOLATILE}
    if isinstance(value, list):
        if len(value) > 64:   # a trajectory: its ends and its length stand for it (keeps the record small)
            value = [*value[:32], {"items": len(value)}, *value[-32:]]
        return [_strip(v) for v in value]
    return value


def _same(a, b, where: str) -> list[str]:
    if isinstance(a, dict) and isinstance(b, dict):
        diffs = [f"{where}.{k}: missing now" for k in a if k not in b]
        diffs += [f"{where}.{k}: new field (record again if intended)" for k in b if k not in a]
        for k in a.keys() & b.keys():
            diffs += _same(a[k], b[k], f"{where}.{k}")
        return diffs
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{where}: {len(a)} items recorded, {len(b)} now"]
        return [d for i, (x, y) in enumerate(zip(a, b)) for d in _same(x, y, f"{where}[{i}]")]
    if isinstance(a, float) and isinstance(b, (int, float)) and not isinstance(b, bool):
        ok = math.isclose(a, b, rel_tol=FLOAT_RTOL, abs_tol=1e-300)
        return [] if ok else [f"{where}: {a!r} recorded, {b!r} now"]
    return [] if a == b else [f"{where}: {a!r} recorded, {b!r} now"]


@pytest.mark.slow
def test_documented_examples_answer_as_recorded(client):
    schema = client.get("/openapi.json").json()
    answers = {}
    for path, i, body in _examples(schema):
        r = client.post(path, json=body)
        answers[f"{path}#{i}"] = {"status": r.status_code, "body": _strip(r.json())}
    if os.environ.get("ZWIDTH_RECORD_ANSWERS") == "1":
        RECORD.write_text(json.dumps(answers, indent=1, sort_keys=True, ensure_ascii=False) + "\n")
        pytest.skip(f"recorded {len(answers)} answers into {RECORD}")
    recorded = json.loads(RECORD.read_text())
    assert len(recorded) >= 20
    diffs = [f"{key}: no longer an example" for key in recorded if key not in answers]
    for key, now in answers.items():
        if key not in recorded:
            diffs.append(f"{key}: a new example, not recorded (record again)")
            continue
        diffs += _same(recorded[key], now, key)
    assert not diffs, "\n".join(diffs[:40])
