"""``verify: true`` over HTTP: the verification record, its absence by default, its input rule."""

from __future__ import annotations

import pytest

from .conftest import LHIFAM_RIGID


def test_stability_verify_confirms_and_is_absent_by_default(client):
    body = {"device": {**LHIFAM_RIGID, "delay": 0.0015}}
    plain = client.post("/v1/analysis/stability", json=body).json()
    assert plain.get("verification") is None
    r = client.post("/v1/analysis/stability", json={**body, "verify": True})
    assert r.status_code == 200
    v = r.json()["verification"]
    assert v["verdict"] == "confirmed", v
    assert v["epsilon"] == 1e-6 and v["elapsed_ms"] > 0 and v["method"]
    k = r.json()["critical_stiffness"]
    assert v["gain_below"] == pytest.approx(k * (1 - 1e-6)) and v["gain_above"] == pytest.approx(k * (1 + 1e-6))
    assert v["radius_below"] < 1 < v["radius_above"]


def test_stability_verify_checks_the_walls_labels(client):
    body = {"device": {"preset": "lhifam", "delay": 0.001}, "controller": {"stiffness": 3500, "damping": 5},
            "verify": True}
    v = client.post("/v1/analysis/stability", json=body).json()["verification"]
    assert v["verdict"] == "confirmed", v
    assert v["design_radius"] < 1
    assert v["passivity"]["verdict"] == "confirmed"


@pytest.mark.slow
def test_the_issue_34_wall_is_not_passive_and_the_labels_say_so(client):
    """The audit's wall: zwidth required 29962.6817 N·s/m and said passive, verify 'confirmed'; the 32-digit sup is
    29962.7703618644 (tests/optim/stability/test_passivity_bound.py).  Now not passive, the required damping at or
    above the sup, and every verify record names the label it confirms (issue 29)."""
    body = {"device": {"sample_time": 1.16184710959797e-05, "delay": 0.0003253171906874316,
                       "mass": 6.442665896890286, "damping": 29962.72},
            "controller": {"stiffness": 680339.6224449361, "damping": 29958.72929925067}, "verify": True}
    r = client.post("/v1/analysis/stability", json=body).json()
    assert r["passive"] is False
    assert 29962.7703618643 <= r["passivity_required_damping"] <= 29962.7703618644 + 4e-9
    v = r["verification"]
    assert v["passivity"]["verdict"] == "confirmed" and v["passivity"]["label"] == "not passive"
    assert v["passivity"]["label_confirmed"] == "not passive"
    if v["verdict"] == "confirmed":
        assert v["label_confirmed"] == v["label"] and v["label"].endswith("not passive")
    assert v["label"].startswith("critical_stiffness = ")
    # a passive wall's record says passive
    ok = client.post("/v1/analysis/stability", json={**body, "device": {**body["device"], "damping": 29962.8}}).json()
    assert ok["passive"] is True and ok["verification"]["passivity"]["label_confirmed"] == "passive"


def test_long_delay_uses_the_argument_principle(client):
    body = {"device": {**LHIFAM_RIGID, "delay": 2.0}, "verify": True}   # 2,000 samples of delay
    v = client.post("/v1/analysis/stability", json=body).json()["verification"]
    assert v["verdict"] == "confirmed", v
    assert v["method"].startswith("argument principle")
    assert v["unstable_poles_below"] == 0 and v["unstable_poles_above"] >= 1


def test_verify_must_be_a_boolean(client):
    r = client.post("/v1/analysis/stability", json={"device": LHIFAM_RIGID, "verify": "yes"})
    assert r.status_code == 422 and "verify" in r.text


@pytest.mark.slow
def test_stiffness_design_verify(client):
    r = client.post("/v1/design/stiffness", json={"device": {**LHIFAM_RIGID, "delay": 0.001},
                                                  "requirements": {"passivity": True}, "verify": True})
    assert r.status_code == 200
    out = r.json()
    assert out["status"] == "optimal"
    v = out["verification"]
    assert v["verdict"] in ("confirmed", "not_checkable"), v   # never contradicted
    assert v["design_radius"] < 1
    assert v["passivity"] is not None
    assert client.post("/v1/design/stiffness", json={"device": LHIFAM_RIGID}).json().get("verification") is None


def test_force_feedforward_verify(client):
    body = {"device": {"preset": "lhifam", "delay": 0.0025}, "filter": {"cutoff_hz": 30, "order": 2}}
    assert client.post("/v1/analysis/force-feedforward", json=body).json().get("verification") is None
    v = client.post("/v1/analysis/force-feedforward", json={**body, "verify": True}).json()["verification"]
    assert v["verdict"] == "confirmed", v
    assert v["radius_below"] < 1 < v["radius_above"]


@pytest.mark.slow
def test_inertia_design_verify(client):
    r = client.post("/v1/design/inertia", json={"device": {"preset": "lhifam"}, "verify": True}).json()
    assert r["status"] == "optimal"
    v = r["verification"]
    assert v["verdict"] == "confirmed", v
    assert v["design_radius"] < 1


def test_boundary_verify(client):
    body = {"device": {**LHIFAM_RIGID, "delay": 0.002}, "points": 8}
    assert client.post("/v1/analysis/boundary", json=body).json().get("verification") is None
    v = client.post("/v1/analysis/boundary", json={**body, "verify": True}).json()["verification"]
    assert v["verdict"] in ("confirmed", "not_checkable"), v
    assert v["reason"].startswith("9 points")


@pytest.mark.slow
def test_robust_stiffness_design_verify(client):
    """A robust wall is verified at every corner of its box (and its worst / least passive device)."""
    body = {"device": LHIFAM_RIGID, "requirements": {"passivity": True, "uncertainty": {
        "device.mass": {"min": 4, "max": 7}, "device.delay": {"min": 0, "max": 0.002}}}, "verify": True}
    r = client.post("/v1/design/stiffness", json=body)
    assert r.status_code == 200, r.text
    out = r.json()
    assert out["robust"] is True and out["status"] == "optimal"
    v = out["verification"]
    assert v["verdict"] == "confirmed", v
    kinds = [p["kind"] for p in v["points"]]
    assert kinds.count("corner") == 4 and "least passive" in kinds
    assert all(p["verdict"] == "confirmed" and p["gain_margin_db"] >= 6.0 for p in v["points"])
    assert {tuple(p["device"]) for p in v["points"]} == {("device.mass", "device.delay")}
    body.pop("verify")
    assert client.post("/v1/design/stiffness", json=body).json()["verification"] is None


@pytest.mark.slow
def test_robust_inertia_design_verify(client):
    body = {"device": LHIFAM_RIGID, "requirements": {"uncertainty": {"device.mass": {"min": 5, "max": 6}}},
            "verify": True}
    r = client.post("/v1/design/inertia", json=body)
    assert r.status_code == 200, r.text
    v = r.json()["verification"]
    assert v["verdict"] == "confirmed", v
    assert sorted(p["device"]["device.mass"] for p in v["points"]) == [5.0, 6.0]
    assert all(p["critical_gain"] > 0 and p["gain_margin_db"] >= 6.0 - 1e-9 for p in v["points"])


@pytest.mark.slow
def test_hardware_design_verify(client):
    body = {"device": {"mass": 5.4, "damping": 3.5, "delay": 0.001}, "target": {"stiffness": 3000},
            "free": "sample_time", "points": 9, "verify": True}
    r = client.post("/v1/design/hardware", json=body)
    assert r.status_code == 200, r.text
    out = r.json()
    assert out["status"] == "optimal"
    v = out["verification"]
    assert v["verdict"] == "confirmed", v
    assert v["design_radius"] < 1
    assert client.post("/v1/plots/hardware", json=body).status_code == 422


def test_hardware_design_verify_without_a_value_says_why(client):
    """The target holds over the whole scanned delay range (bounded: false, value null): verify answered nothing
    at all where it was asked for; now not checkable with the reason."""
    body = {"device": {"mass": 5.4, "damping": 0.0, "sample_time": 1e-3}, "target": {"stiffness": 1000},
            "free": "delay", "points": 9, "verify": True}
    out = client.post("/v1/design/hardware", json=body).json()
    assert out["status"] == "optimal" and out["value"] is None and out["bounded"] is False, out
    v = out["verification"]
    assert v["verdict"] == "not_checkable" and "no value of the free parameter" in v["reason"], v
