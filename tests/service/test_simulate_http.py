"""POST /v1/simulate and /v1/plots/simulation through the app factory."""

import math

import pytest
from fastapi.testclient import TestClient

from models.simulation.scene import MAX_OUTPUT_POINTS
from service.app import create_app

RIGID = {"mass": 5.4, "damping": 3.5, "sample_time": 0.001}


@pytest.fixture(scope="module")
def client():
    return TestClient(create_app())


def _finite_everywhere(obj):
    if isinstance(obj, float):
        return math.isfinite(obj)
    if isinstance(obj, dict):
        return all(_finite_everywhere(v) for v in obj.values())
    if isinstance(obj, list):
        return all(_finite_everywhere(v) for v in obj)
    return True


def test_release_answer(client):
    r = client.post("/v1/simulate", json={"device": RIGID, "scene": {
        "experiment": "release", "duration": 12.0, "controller": {"stiffness": 1.05 * 7000.756},
        "initial": {"position": 1e-3}, "output_points": 500}})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["method"] == "exact-linear-recursion" and body["effects_simulated"] == ["zoh", "sampling"]
    assert body["verdict"]["state"] == "unstable" and body["verdict"]["growth_rate"] > 0
    assert len(body["trajectory"]["time"]) == 500 and body["relay"] is None and body["elapsed_ms"] > 0
    assert _finite_everywhere(body)


@pytest.mark.slow
def test_relay_answer_lists_cycles(client):
    r = client.post("/v1/simulate", json={"device": {"preset": "lhifam", "cable": None}, "scene": {
        "experiment": "relay", "duration": 20.0, "relay": {"amplitude": 1.0}, "initial": {"position": 3e-3}}})
    assert r.status_code == 200, r.text
    relay = r.json()["relay"]
    assert relay["settled"]["pattern"] == [115] and relay["settled"]["symmetric"]
    assert any(a <= 115 <= b for a, b in relay["admissible_half_periods"])
    assert relay["critical_stiffness"] == pytest.approx(7000.756, rel=1e-6)
    assert len(relay["cycles"]) == relay["searched_half_periods"]
    assert _finite_everywhere(r.json())


@pytest.mark.parametrize("scene,field", [
    ({"experiment": "release", "duration": 2500.0, "controller": {"stiffness": 1.0}}, "duration"),
    ({"experiment": "release", "duration": 1.0, "controller": {"stiffness": 1.0}, "output_points": MAX_OUTPUT_POINTS + 1},
     "output_points"),
    ({"experiment": "release", "duration": 1.0}, "controller"),
    ({"experiment": "release", "duration": 1.0, "controller": {"stiffness": 1.0}, "effects": {"cable_mode": {}}},
     "cable_mode"),
])
def test_bad_scenes_answer_422_naming_the_field(client, scene, field):
    r = client.post("/v1/simulate", json={"device": RIGID, "scene": scene})
    assert r.status_code == 422
    assert field in r.text


def test_nan_is_422_not_500(client):
    body = '{"device": {"mass": 5.4, "damping": 3.5}, "scene": {"experiment": "release", "duration": NaN, ' \
           '"controller": {"stiffness": 1}}}'
    r = client.post("/v1/simulate", content=body, headers={"content-type": "application/json"})
    assert r.status_code == 422


@pytest.mark.slow
@pytest.mark.parametrize("fmt,magic", [("png", b"\x89PNG"), ("svg", b"<?xml")])
def test_plot(client, fmt, magic):
    r = client.post(f"/v1/plots/simulation?format={fmt}", json={"device": RIGID, "scene": {
        "experiment": "release", "duration": 1.0, "controller": {"stiffness": 3000}, "initial": {"position": 1e-3}}})
    assert r.status_code == 200 and r.content.startswith(magic)


def test_verdict_block_carries_the_poles_and_the_measured_verdict(client):
    """Issue 17's example (2.9 × K_cr, 1 s): the poles decide unstable; the measured verdict is beside it."""
    r = client.post("/v1/simulate", json={"device": {"preset": "lhifam", "cable": None}, "scene": {
        "experiment": "release", "duration": 1.0, "controller": {"stiffness": 20000}, "initial": {"position": 1e-3}}})
    assert r.status_code == 200, r.text
    v = r.json()["verdict"]
    assert v["state"] == "unstable" and v["decided_by"] == "closed-loop poles" and v["disagreement"] is None
    p = v["poles"]
    assert p["state"] == "unstable" and not p["linearised"] and p["states"] == 4
    assert p["spectral_radius"] == p["dominant_pole"]["modulus"] and 1.0005 < p["spectral_radius"] < 1.0007
    assert v["frequency"] == pytest.approx(p["dominant_pole"]["frequency"]) and v["growth_rate"] > 0
    assert v["measured"]["state"] in ("unstable", "undetermined") and v["measured"]["reason"]
    assert _finite_everywhere(r.json())


@pytest.mark.slow
def test_openapi_examples_give_a_verdict_the_poles_agree_with(client):
    """The request examples of /docs: the stable wall (0.93 × K_cr, poles) and the relay (measured)."""
    from service.schemas.simulate import SimulateRequest

    stable, relay = SimulateRequest.model_config["json_schema_extra"]["examples"]
    v = client.post("/v1/simulate", json=stable).json()["verdict"]
    assert v["state"] == "stable" and v["decided_by"] == "closed-loop poles"
    v = client.post("/v1/simulate", json=relay).json()["verdict"]
    assert v["decided_by"] == "trajectory" and v["poles"] is None and "relay" in v["poles_note"]
    assert v["state"] == "limit_cycle"
