"""Shared pieces of the study tests: a small stability study and a poller."""

from __future__ import annotations

import time

LHIFAM_RIGID = {"mass": 5.4, "damping": 3.5, "sample_time": 0.001}  # chapter Table 2 (rigid LHifAM)


def small_study(num_delay: int = 4) -> dict:
    """A rigid-LHifAM wall checked over delay × virtual damping (num_delay × 2 points)."""
    return {"problem": "stability",
            "base": {"device": LHIFAM_RIGID, "requirements": {"stiffness": 1500.0}},
            "sweep": {"device.delay": {"start": 0.0, "stop": 0.003, "num": num_delay},
                      "requirements.damping": [0.0, 5.0]}}


def wait_finished(get, study_id: str, timeout: float = 60.0) -> dict:
    """Poll GET /v1/studies/{id} (``get`` returns the JSON) until the study is no longer active."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        st = get(study_id)
        if st["status"] not in ("queued", "running", "cancelling"):
            return st
        time.sleep(0.1)
    raise AssertionError(f"study {study_id} did not finish within {timeout} s: {st}")
