"""POST /v1/identify and /v1/plots/identify over HTTP: the answer's contract, its device and uncertainty accepted
by the other endpoints, every bad-data rule a 422 naming the field, a failed fit without a device."""

from __future__ import annotations

import json

import numpy as np
import pytest

from models.device import Device
from optim.identification.data import MAX_SAMPLES
from optim.identification.models import response
from tests.optim.identification.cases import record

from .conftest import make_client

DEV = Device(mass=5.4, damping=3.5, delay=0.0013)


def _fr(points=40, rel_noise=0.005, seed=1, device=DEV):
    w = np.geomspace(2 * np.pi, 2 * np.pi * 300, points)
    h = response(device, w, "continuous")
    rng = np.random.default_rng(seed)
    h = h * (1 + rel_noise * (rng.normal(size=points) + 1j * rng.normal(size=points)) / np.sqrt(2))
    return {"kind": "frequency_response", "frequency": w.tolist(), "real": h.real.tolist(), "imag": h.imag.tolist()}


def _ts(n=2000):
    d = record("rigid", 0.0013)
    return {"kind": "time_series", "sample_time": 0.001, "force": d.force[:n].tolist(),
            "position": d.position[:n].tolist()}


@pytest.fixture(scope="module")
def client():
    with make_client(inline_cost_ms=25) as c:
        yield c


@pytest.fixture(scope="module")
def identified(client):
    r = client.post("/v1/identify", json={"model": "rigid", "data": _fr()})
    assert r.status_code == 200, r.text
    return r.json()


def test_answer_follows_the_contract(identified):
    body = identified
    assert body["status"] == "identified" and body["model"] == "rigid"
    assert set(body["parameters"]) == {"mass", "damping", "delay"}
    for name, p in body["parameters"].items():
        lo, hi = p["interval"]
        assert lo <= p["value"] <= hi and p["std_error"] > 0
        assert body["uncertainty"][f"device.{name}"] == {"min": lo, "max": hi}
    assert body["parameters"]["mass"]["value"] == pytest.approx(5.4, rel=0.01)
    assert abs(body["parameters"]["delay"]["value"] - 0.0013) < 0.00005
    fit = body["fit"]
    assert 0 <= fit["nrmse"] < 0.05 and fit["residual_whiteness"]["test"] == "ljung-box"
    assert len(fit["residual_autocorrelation"]) == fit["residual_whiteness"]["lags"]
    assert [c["model"] for c in body["comparison"]] == ["rigid"] and body["elapsed_ms"] > 0
    assert body["confidence"] == 0.95


def test_device_is_accepted_by_the_analysis(client, identified):
    dev = identified["device"]
    r = client.post("/v1/analysis/stability", json={"device": dev})
    assert r.status_code == 200, r.text
    # the analysis of the identified device is the analysis of those numbers
    same = client.post("/v1/analysis/stability", json={"device": {
        "mass": dev["mass"], "damping": dev["damping"], "delay": dev["delay"], "sample_time": 0.001}})
    assert r.json()["critical_stiffness"] == same.json()["critical_stiffness"]


def test_uncertainty_is_accepted_by_the_robust_design(client, identified):
    r = client.post("/v1/design/stiffness", json={"device": identified["device"],
                                                  "requirements": {"uncertainty": identified["uncertainty"]}})
    assert r.status_code == 200, r.text
    assert r.json()["status"] == "optimal" and r.json()["robust"] is True


def test_time_series(client):
    r = client.post("/v1/identify", json={"model": "rigid", "data": _ts(), "confidence": 0.9})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["status"] == "identified" and body["confidence"] == 0.9
    assert body["parameters"]["mass"]["value"] == pytest.approx(5.4, rel=0.01)


@pytest.mark.slow
def test_failed_fit_has_no_device(client):
    r = client.post("/v1/identify", json={"model": "cable", "data": _fr()})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["status"] == "failed" and body["device"] is None and body["uncertainty"] == {}
    assert body["reason"].startswith("the cable fit failed")


def _loc_msg(r):
    assert r.status_code == 422, r.text
    d = r.json()["detail"][0]
    return d["loc"], d["msg"]


def test_lengths_differ(client):
    ts = _ts(500)
    ts["position"] = ts["position"][:-1]
    loc, msg = _loc_msg(client.post("/v1/identify", json={"data": ts}))
    assert loc == ["body", "data", "position"] and "as many values" in msg
    fr = _fr()
    fr["imag"] = fr["imag"][:-1]
    loc, msg = _loc_msg(client.post("/v1/identify", json={"data": fr}))
    assert loc == ["body", "data", "real"] and "same length" in msg


def test_non_finite(client):
    ts = _ts(200)
    text = json.dumps({"data": ts}).replace(str(ts["force"][5]), "NaN", 1)
    loc, msg = _loc_msg(client.post("/v1/identify", content=text, headers={"content-type": "application/json"}))
    assert loc == ["body", "data", "time_series", "force", 5] and "finite" in msg


def test_too_few_samples(client):
    loc, msg = _loc_msg(client.post("/v1/identify", json={"model": "rigid", "data": _ts(30)}))
    assert loc == ["body", "data", "force"] and "too few for 4 free parameters" in msg


def test_too_many_samples(client):
    big = {"kind": "time_series", "force": [0.0] * (MAX_SAMPLES + 1), "position": [0.0] * (MAX_SAMPLES + 1)}
    r = make_client(max_body_bytes=10_000_000).post("/v1/identify", json={"data": big})
    loc, msg = _loc_msg(r)
    assert loc[:3] == ["body", "data", "time_series"] and "200000" in msg


def test_input_not_exciting(client):
    n = 1000
    flat = {"kind": "time_series", "force": [1.0] * n, "position": (np.arange(n) ** 2 * 1e-7).tolist()}
    loc, msg = _loc_msg(client.post("/v1/identify", json={"data": flat}))
    assert loc == ["body", "data", "force"] and "constant" in msg
    t = np.arange(4000) * 0.001
    u = np.sin(2 * np.pi * 40 * t)
    sine = {"kind": "time_series", "force": u.tolist(), "position": (np.cumsum(np.cumsum(u)) * 1e-7).tolist()}
    loc, msg = _loc_msg(client.post("/v1/identify", json={"model": "rigid", "data": sine}))
    assert loc == ["body", "data", "force"] and "too narrow a band for the rigid model" in msg


def test_response_with_too_few_points(client):
    loc, msg = _loc_msg(client.post("/v1/identify", json={"model": "cable", "data": _fr(points=10)}))
    assert loc == ["body", "data", "frequency"] and "too few for 7 free parameters" in msg


def test_bad_options(client):
    loc, _ = _loc_msg(client.post("/v1/identify", json={"model": "rigid", "data": _fr(), "known": {"bogus": 1}}))
    assert loc == ["body", "known", "bogus"]
    loc, _ = _loc_msg(client.post("/v1/identify", json={"data": _fr(), "friction": True}))
    assert loc == ["body", "friction"]
    loc, _ = _loc_msg(client.post("/v1/identify", json={"data": _fr(), "model": "stiff"}))
    assert loc == ["body", "model"]


@pytest.mark.slow
@pytest.mark.parametrize("fmt,media", (("png", "image/png"), ("svg", "image/svg+xml")))
def test_plot(client, fmt, media):
    r = client.post(f"/v1/plots/identify?format={fmt}", json={"model": "rigid", "data": _fr()})
    assert r.status_code == 200 and r.headers["content-type"] == media
    assert r.content[:4] == b"\x89PNG" if fmt == "png" else b"<svg" in r.content[:400]


@pytest.mark.slow
def test_time_series_plot(client):
    r = client.post("/v1/plots/identify", json={"model": "rigid", "data": _ts(), "format": "svg"})
    assert r.status_code == 200 and r.headers["content-type"] == "image/svg+xml"
    failed = client.post("/v1/plots/identify", json={"model": "cable", "data": _fr()})
    assert failed.status_code == 200 and failed.content[:4] == b"\x89PNG"     # says why it failed


def test_cable_device_and_uncertainty_are_accepted(client):
    """A cable device's answer: its device analysed by /v1/analysis/stability, its seven-path uncertainty box
    accepted by the robust design's own validation (optim.robust.box, what requirements.uncertainty runs)."""
    from optim.robust.box import UncertaintyBox

    cable = Device(cable={"motor_mass": 0.3, "motor_damping": 0.1, "body_mass": 5.1, "body_damping": 3.4,
                          "stiffness": 79500.0, "damping": 15.0}, delay=0.0013)
    r = client.post("/v1/identify", json={"model": "auto", "data": _fr(points=60, device=cable)})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["status"] == "identified" and body["model"] == "cable", body["reason"]
    assert set(body["device"]["cable"]) == {"motor_mass", "motor_damping", "body_mass", "body_damping", "stiffness",
                                            "damping"}
    s = client.post("/v1/analysis/stability", json={"device": body["device"]})
    assert s.status_code == 200, s.text
    ranges = {k: (v["min"], v["max"]) for k, v in body["uncertainty"].items()}
    assert len(ranges) == 7
    box = UncertaintyBox.from_ranges(Device.model_validate(body["device"]), ranges)
    assert box.dim == 7


@pytest.mark.slow
def test_documented_example_is_identified(client):
    example = client.get("/openapi.json").json()["components"]["schemas"]["IdentifyRequest"]["examples"][0]
    r = client.post("/v1/identify", json=example)
    assert r.status_code == 200 and r.json()["status"] == "identified" and r.json()["model"] == "rigid"
    assert abs(r.json()["device"]["delay"] - 0.0015) < 0.00005
