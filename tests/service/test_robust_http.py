"""POST /v1/design/stiffness with requirements.uncertainty, /v1/design/hardware and their plots over HTTP."""

import math
import warnings

import pytest

with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    from fastapi.testclient import TestClient

from models.device import Device
from models.feedforward import feedforward_plant
from optim.stability.margins import critical_stiffness
from optim.stability.passivity import passivity_margin
from optim.transparency.feedforward import critical_force_gain_of_plant, resolve_human
from service.app import create_app

LH_RIGID = {"preset": "lhifam", "cable": None}
UNC = {"device.mass": {"min": 4, "max": 7}, "device.delay": {"min": 0, "max": 0.002}}


@pytest.fixture(scope="module")
def client():
    return TestClient(create_app())


@pytest.mark.slow
def test_robust_design(client):
    r = client.post("/v1/design/stiffness", json={"device": LH_RIGID, "requirements": {"uncertainty": UNC}})
    assert r.status_code == 200
    body = r.json()
    assert body["status"] == "optimal" and body["robust"] is True
    assert body["gain_margin_db"] >= 6 - 1e-6
    worst = body["worst_case"]
    dev = Device(mass=worst["device"]["device.mass"], damping=3.5, delay=worst["device"]["device.delay"])
    kcr = critical_stiffness(dev, body["damping"]).critical_stiffness
    assert kcr == pytest.approx(worst["critical_stiffness"], rel=1e-9)
    assert 20 * math.log10(kcr / body["stiffness"]) == pytest.approx(body["gain_margin_db"], abs=1e-9)
    assert body["iterations"] >= 1 and len(body["scenarios"]) >= 5 and body["evaluations"] > 0
    assert body["nominal_gain_margin_db"] > body["gain_margin_db"]


def test_nominal_request_unchanged(client):
    body = client.post("/v1/design/stiffness", json={"device": LH_RIGID}).json()
    assert body["robust"] is False and body["worst_case"] is None


@pytest.mark.parametrize("unc,loc_end,fragment", [
    ({"device.mass": {"min": -1, "max": 7}}, "device.mass", "greater than 0"),
    ({"device.mass": {"min": 7, "max": 4}}, "device.mass", "≤ max"),
    ({"device.nope": {"min": 1, "max": 2}}, "device.nope", "unknown path"),
    ({"device.mass": {"min": 1}}, "max", "required"),
])
def test_bad_uncertainty_is_422_naming_the_field(client, unc, loc_end, fragment):
    r = client.post("/v1/design/stiffness", json={"device": LH_RIGID, "requirements": {"uncertainty": unc}})
    assert r.status_code == 422
    err = r.json()["detail"][0]
    assert err["loc"][-1] == loc_end and fragment in err["msg"]


def test_nan_range_is_422(client):
    body = '{"device": {"preset": "lhifam", "cable": null}, "requirements": {"uncertainty": ' \
           '{"device.mass": {"min": NaN, "max": 7}}}}'
    r = client.post("/v1/design/stiffness", content=body, headers={"content-type": "application/json"})
    assert r.status_code == 422


def test_hardware(client):
    r = client.post("/v1/design/hardware", json={"device": LH_RIGID, "target": {"stiffness": 2e5}, "free": "delay",
                                                 "points": 11})
    assert r.status_code == 200
    body = r.json()
    assert body["status"] == "optimal" and body["direction"] == "max" and body["bounded"]
    assert body["controller"]["gain_margin_db"] == pytest.approx(6.0, abs=1e-6)
    assert len(body["curve"]) == 11 and body["intervals"][0][1] == pytest.approx(body["value"])


def test_hardware_infeasible_and_bad_free(client):
    body = client.post("/v1/design/hardware", json={"device": LH_RIGID, "target": {"stiffness": 1e12},
                                                    "free": "delay", "points": 9}).json()
    assert body["status"] == "infeasible" and body["value"] is None and body["limiting_effect"]
    assert "physical bound delay = 0" in body["range_source"] and not body["limiting_effect"].startswith("loop")
    r = client.post("/v1/design/hardware", json={"device": LH_RIGID, "target": {"stiffness": 1e4},
                                                 "free": "cable.stiffness"})
    assert r.status_code == 422 and r.json()["detail"][0]["loc"][-1] == "free"
    r = client.post("/v1/design/hardware", json={"device": LH_RIGID, "target": {"stiffness": 1e4}, "free": "color"})
    assert r.status_code == 422


def test_hardware_range(client):
    """``range`` is scanned as given; an empty range or one outside the input limits is a 422 naming the field."""
    dev = {"mass": 1, "damping": 0.1, "sample_time": 0.001, "delay": 0.001}
    body = client.post("/v1/design/hardware", json={"device": dev, "target": {"stiffness": 75e3}, "free": "damping",
                                                    "points": 9, "range": {"min": 1, "max": 30}}).json()
    assert body["status"] == "optimal" and body["range_source"] == "request" and body["scanned_range"] == [1, 30]
    assert 10 < body["value"] < 10.2                       # b ≈ 10.08 N·s/m (tests/optim/hardware/test_hardware_range.py)
    for rng, field, rule in (({"min": 3, "max": 3}, "min", "must be below range.max"),
                             ({"min": 1e-4, "max": 2}, "max", "outside the input limits"),
                             ({"min": -1, "max": 2}, "min", "greater than or equal to 0")):
        r = client.post("/v1/design/hardware", json={"device": dev, "target": {"stiffness": 75e3},
                                                     "free": "sample_time", "range": rng})
        assert r.status_code == 422, r.text
        detail = r.json()["detail"][0]
        assert detail["loc"][-2:] == ["range", field] or detail["loc"][-1] == field, detail
        assert rule in detail["msg"]


@pytest.mark.slow
def test_hardware_force_feedforward_target(client):
    """A stiffness and a force-gain target over HTTP: the force gain limits; the JSON carries both parts."""
    r = client.post("/v1/design/hardware", json={"device": LH_RIGID, "target": {"stiffness": 2e5, "force_gain": 9},
                                                 "free": "delay", "points": 9})
    assert r.status_code == 200
    body = r.json()
    assert body["status"] == "optimal" and body["limiting_target"] == "force_gain"
    assert body["edges"] == [{"value": body["value"], "limiting_target": "force_gain"}]
    c = body["controller"]
    assert c["force_gain"] == 9 and c["force_gain_margin_db"] == pytest.approx(6.0, abs=1e-6)
    assert c["gain_margin_db"] > 6.0 and c["achievable_stiffness"] > 2e5 and c["filter_order"] == 2
    # the exact K_f,cr at the returned cutoff, from the analysis route (a second code path)
    dev = {**LH_RIGID, "delay": body["value"]}
    ff = client.post("/v1/analysis/force-feedforward", json={"device": dev, "filter": {
        "cutoff_hz": c["filter_cutoff_hz"], "order": 2}}).json()
    assert 20 * math.log10(ff["critical_force_gain"] / 9) == pytest.approx(6.0, abs=1e-6)
    assert all(p["achievable_force_gain"] > 0 and p["achievable_stiffness"] > 0 for p in body["curve"])


@pytest.mark.slow
def test_hardware_apparent_mass_alone(client):
    body = client.post("/v1/design/hardware", json={"device": LH_RIGID, "target": {"apparent_mass": 0.5},
                                                    "free": "mass", "points": 9}).json()
    assert body["status"] == "optimal" and body["direction"] == "max" and body["limiting_target"] == "apparent_mass"
    assert body["controller"]["apparent_mass"] == pytest.approx(0.5, rel=1e-12)
    assert body["controller"]["stiffness"] is None and body["curve"][0]["achievable_stiffness"] is None


@pytest.mark.parametrize("target,free,field", [
    ({"force_gain": 5, "apparent_mass": 0.5}, "delay", "apparent_mass"),
    ({"min_gain_margin_db": 6}, "delay", "stiffness"),
    ({"apparent_mass": 5.4}, "delay", "apparent_mass"),           # not below the device's mass
    ({"force_gain": 0}, "delay", "force_gain"),
    ({"force_gain": 5, "max_damping": 10}, "delay", "max_damping"),
    ({"stiffness": 2e5, "filter_order": 2}, "delay", "filter_order"),
    ({"force_gain": 5, "filter_order": 9}, "delay", "filter_order"),
])
def test_hardware_bad_target_is_422_naming_the_field(client, target, free, field):
    r = client.post("/v1/design/hardware", json={"device": LH_RIGID, "target": target, "free": free, "points": 9})
    assert r.status_code == 422
    assert r.json()["detail"][0]["loc"][-2:] == ["target", field]
    r = client.post("/v1/plots/hardware", json={"device": LH_RIGID, "target": target, "free": free, "points": 9})
    assert r.status_code == 422 and r.json()["detail"][0]["loc"][-1] == field


@pytest.mark.slow
def test_hardware_plot_with_force_target(client):
    r = client.post("/v1/plots/hardware?format=svg", json={"device": LH_RIGID, "target": {
        "stiffness": 2e5, "force_gain": 9}, "free": "delay", "points": 9})
    assert r.status_code == 200 and r.content.startswith(b"<?xml")
    assert b"K_f*" in r.content or b"force gain" in r.content


@pytest.mark.slow
@pytest.mark.parametrize("fmt,magic", [("png", b"\x89PNG"), ("svg", b"<?xml")])
def test_plots(client, fmt, magic):
    r = client.post(f"/v1/plots/robust?format={fmt}", json={"device": LH_RIGID, "requirements": {"uncertainty": UNC},
                                                            "points": 9})
    assert r.status_code == 200 and r.content.startswith(magic)
    r = client.post(f"/v1/plots/hardware?format={fmt}", json={"device": LH_RIGID, "target": {"stiffness": 2e5},
                                                              "free": "delay", "points": 9})
    assert r.status_code == 200 and r.content.startswith(magic)


def test_robust_plot_bad_axis(client):
    r = client.post("/v1/plots/robust", json={"device": LH_RIGID, "requirements": {"uncertainty": UNC},
                                              "x": "device.damping", "points": 9})
    assert r.status_code == 422 and r.json()["detail"][0]["loc"][-1] == "x"


@pytest.mark.slow
def test_robust_inertia(client):
    r = client.post("/v1/design/inertia", json={"device": {"preset": "lhifam"}, "requirements": {
        "uncertainty": {"device.human.mass": {"min": 0.5, "max": 4}}}})
    assert r.status_code == 200
    body = r.json()
    assert body["robust"] is True and body["status"] == "optimal"
    assert body["gain_margin_db"] == pytest.approx(6.0, abs=1e-6)
    assert body["worst_case"]["device"] == {"device.human.mass": 4.0}
    assert body["critical_force_gain"] / body["force_gain"] == pytest.approx(10 ** (6 / 20), rel=1e-9)


@pytest.mark.slow
def test_robust_inertia_with_sample_time(client):
    r = client.post("/v1/design/inertia", json={"device": {"preset": "lhifam"}, "requirements": {
        "uncertainty": {"device.sample_time": {"min": 0.0005, "max": 0.001}}}})
    assert r.status_code == 200
    body = r.json()
    assert body["status"] == "optimal" and body["gain_margin_db"] == pytest.approx(6.0, abs=1e-6)
    worst = body["worst_case"]["device"]["device.sample_time"]
    # the worst device at its own cutoff angle 2π·f_c·T (optim.transparency.feedforward, a fresh plant)
    dev = Device(preset="lhifam", sample_time=worst)
    human, _ = resolve_human(dev)
    theta_c = 2 * math.pi * body["filter_cutoff_hz"] * worst
    kcr = critical_force_gain_of_plant(feedforward_plant(dev, human), theta_c, 2)[0]
    assert kcr == pytest.approx(body["critical_force_gain"], rel=1e-9)
    assert len(body["pareto"]) == 17
    rm = body["rigid_model"]
    assert rm["optimism"] == pytest.approx(rm["critical_force_gain"] / body["critical_force_gain"] - 1, rel=1e-12)
    assert any("pareto" in n for n in body["notes"])


def test_robust_inertia_cutoff_above_a_corners_nyquist_is_422(client):
    r = client.post("/v1/design/inertia", json={"device": {"preset": "lhifam"}, "requirements": {
        "cutoff_max_hz": 300, "uncertainty": {"device.sample_time": {"min": 0.0005, "max": 0.002}}}})
    assert r.status_code == 422 and r.json()["detail"][0]["loc"][-1] == "cutoff_max_hz"


def test_robust_with_passivity(client):
    r = client.post("/v1/design/stiffness", json={"device": LH_RIGID, "requirements": {
        "passivity": True, "uncertainty": {"device.sample_time": {"min": 0.0008, "max": 0.0012},
                                           "device.delay": {"min": 0.001, "max": 0.002}}}})
    assert r.status_code == 200
    body = r.json()
    assert body["status"] == "optimal" and "passivity" in body["active_constraints"]
    pw = body["passivity_worst_case"]
    assert pw["delay_samples_used"] == 3 and pw["approached"] is True and body["passivity_delay_samples"] == 3
    # the least passive device, just below its sample time, re-checked by optim.stability.passivity
    dev = Device(mass=5.4, damping=3.5, sample_time=pw["device"]["device.sample_time"] * (1 - 1e-9),
                 delay=pw["device"]["device.delay"])
    check = passivity_margin(dev, body["stiffness"], body["damping"])
    assert check.delay_samples_used == 3
    assert 3.5 - check.required_damping == pytest.approx(pw["passivity_margin"], abs=1e-6)
    assert pw["passivity_margin"] >= -1e-9 and "rounded up" in body["passivity_note"]


def test_robust_with_passivity_too_many_delays_is_422(client):
    r = client.post("/v1/design/stiffness", json={"device": LH_RIGID, "requirements": {
        "passivity": True, "uncertainty": {"device.delay": {"min": 0, "max": 0.1}}}})
    assert r.status_code == 422 and r.json()["detail"][0]["loc"][-1] == "uncertainty"
    assert "at most 64" in r.json()["detail"][0]["msg"]
