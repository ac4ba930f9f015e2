"""The analysis endpoints answer exactly what the numerics answer: the service adds nothing numerical.

Every JSON number is compared with ``==`` to the value optim computes in this
process for the same input: JSON carries floats as their shortest repr, which
round-trips to the same double, so any difference is the service's doing.
The physics itself is verified in tests/optim; here two chapter values are
re-checked as a guard that the right function is wired to the right route.
"""

from __future__ import annotations

import math
from dataclasses import asdict

import pytest

from models.device import PRESETS, Device
from optim.stability.analysis import analyse_stability
from optim.stability.boundary import stability_boundary

from .conftest import LHIFAM_RIGID

# Fields that legitimately differ between two runs: wall-clock time.
_TIMING = {"elapsed_ms"}


def expected_stability(device_json: dict, stiffness=None, damping=0.0, method="exact", grid_points=1000) -> dict:
    res = asdict(analyse_stability(Device(**device_json), stiffness, damping, method, grid_points))
    res.pop("stiffness")  # the request's own K, not part of the answer
    res["verification"] = None  # only with verify: true (tests/service/test_verify_routes.py)
    res.pop("mass_range")  # only when the controller names mass or velocity_filter (test_rendered_routes.py)
    return res


def assert_same(answer: dict, expected: dict) -> None:
    assert set(answer) == set(expected), set(answer) ^ set(expected)
    for key, value in expected.items():
        if key in _TIMING:
            assert answer[key] >= 0
            continue
        if key == "crossovers":
            assert answer[key] == [{"frequency": c["frequency"], "stiffness": c["stiffness"]} for c in value]
            continue
        if isinstance(value, float) and not math.isfinite(value):
            assert answer[key] is None, key  # JSON has no inf: null (the schema says when)
            continue
        assert answer[key] == value, key  # bit-for-bit: see the module docstring


CASES = [
    ({"preset": name}, None, 0.0) for name in sorted(PRESETS)
] + [
    ({"preset": name, "cable": None}, 1000.0, 2.0) for name in sorted(PRESETS)
] + [
    (LHIFAM_RIGID, None, 0.0),
    ({**LHIFAM_RIGID, "delay": 0.00137}, 2500.0, 4.0),  # fractional delay
    ({"preset": "lhifam", "delay": 0.003}, 500.0, 10.0),
    ({"mass": 1.0, "damping": 0.0}, 100.0, 5.0),  # no physical damping, virtual damping only
]


@pytest.mark.parametrize("device,stiffness,damping", CASES)
def test_stability_matches_core_exactly(client, device, stiffness, damping):
    body = {"device": device}
    if stiffness is not None:
        body["controller"] = {"stiffness": stiffness, "damping": damping}
    r = client.post("/v1/analysis/stability", json=body)
    assert r.status_code == 200, r.text
    assert_same(r.json(), expected_stability(device, stiffness, damping))


@pytest.mark.parametrize("method", ["linear", "grid", "exact"])
def test_each_rung_says_which_it_is_and_matches_core(client, method):
    body = {"device": {"preset": "lhifam"}, "controller": {"stiffness": 3000.0, "damping": 1.0}, "method": method,
            "grid_points": 500}
    r = client.post("/v1/analysis/stability", json=body)
    assert r.status_code == 200, r.text
    assert r.json()["method"] == method
    assert_same(r.json(), expected_stability({"preset": "lhifam"}, 3000.0, 1.0, method, 500))


@pytest.mark.slow
def test_reference_rung_runs_in_a_worker_and_matches_core(client):
    """method=reference is costed above the inline threshold: it travels through a worker process and back."""
    device = {"mass": 5.4, "damping": 3.5, "delay": 0.0005}
    r = client.post("/v1/analysis/stability", json={"device": device, "method": "reference"})
    assert r.status_code == 200, r.text
    assert r.json()["method"] == "reference"
    assert_same(r.json(), expected_stability(device, method="reference"))


def test_chapter_values_reach_the_client(client):
    """Chapter Table 3: LHifAM rigid 76.9 dB, cable 78.9 dB (printed to 0.1 dB; the exact values are
    asserted in tests/optim)."""
    rigid = client.post("/v1/analysis/stability", json={"device": LHIFAM_RIGID}).json()
    cable = client.post("/v1/analysis/stability", json={"device": {"preset": "lhifam"}}).json()
    assert 20 * math.log10(rigid["critical_stiffness"]) == pytest.approx(76.9, abs=0.05)  # printed to 0.1 dB
    assert 20 * math.log10(cable["critical_stiffness"]) == pytest.approx(78.9, abs=0.05)
    assert rigid["method"] == "exact" and rigid["elapsed_ms"] > 0


@pytest.mark.slow
@pytest.mark.parametrize("device,damping_max,points", [
    (LHIFAM_RIGID, None, 12),
    ({"preset": "lhifam"}, 40.0, 9),
    ({"mass": 0.8, "damping": 0.5, "delay": 0.0025}, None, 7),
])
def test_boundary_matches_core_exactly(client, device, damping_max, points):
    body = {"device": device, "points": points}
    if damping_max is not None:
        body["damping_max"] = damping_max
    r = client.post("/v1/analysis/boundary", json=body)
    assert r.status_code == 200, r.text
    got = r.json()
    ref = stability_boundary(Device(**device), damping_max, points)

    def point(p):
        d = asdict(p)
        if not math.isfinite(d["critical_stiffness"]):
            d["critical_stiffness"] = None  # "every K stable": null plus the reason, never a non-finite number
        return d
    assert got["points"] == [point(p) for p in ref.points]
    assert got["optimum"] == point(ref.optimum)
    assert got["max_stable_damping"] == ref.max_stable_damping
    assert got["method"] == "exact" and got["elapsed_ms"] > 0
    assert got["optimum"]["critical_stiffness"] >= max(p["critical_stiffness"] or 0 for p in got["points"])


def test_gain_margin_is_reported_for_a_given_wall(client):
    r = client.post("/v1/analysis/stability",
                    json={"device": LHIFAM_RIGID, "controller": {"stiffness": 3500.0, "damping": 0.0}}).json()
    # Definition (eq. 13): 20·log10(K_cr/K); the core's own value is compared exactly above.
    assert r["gain_margin_db"] == pytest.approx(20 * math.log10(r["critical_stiffness"] / 3500.0), rel=1e-14)
    assert r["stable"] is True


def test_stable_band_past_b_max_reaches_the_client(client):
    """Issue 34: K_cr = 0 past B_max with a band of stable K: the answer carries it, the client model reads it."""
    from clients.schemas import StabilityResponse as ClientStability
    from tests.optim.stability.test_near_b_max_band import BAND_B, BAND_CABLE

    r = client.post("/v1/analysis/stability", json={"device": BAND_CABLE,
                                                    "controller": {"stiffness": 0.01, "damping": BAND_B}})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["critical_stiffness"] == 0.0 and body["stable"] is True
    lo, hi = body["stable_band"]
    assert lo < 0.01 < hi
    assert ClientStability.model_validate(body).stable_band == [lo, hi]
