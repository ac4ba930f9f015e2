"""POST /v1/design/stiffness with requirements.uncertainty and a rendered wall (issue 30): the robust box with a fixed
velocity filter through HTTP (its numbers are optim.robust.rendered_stiffness's, tested in
tests/optim/robust/test_robust_rendered.py), its verify closed with the filter's states, and the refusals."""

from __future__ import annotations

import math

import pytest

from models.device import Device
from models.velocity_filter import LowPass, rendering
from optim.stability.rendered import rendered_critical_stiffness
from tests.service.conftest import make_client

DEV = {"mass": 5.4, "damping": 3.5, "sample_time": 0.001, "delay": 0.0005}
UNC = {"device.mass": {"min": 4.5, "max": 6.5}, "device.damping": {"min": 2.0, "max": 5.0},
       "device.delay": {"min": 0.0002, "max": 0.0008}}
LP50 = {"kind": "low_pass", "cutoff_hz": 50, "order": 1}
PATH = "/v1/design/stiffness"


@pytest.fixture(scope="module")
def client():
    with make_client(request_timeout=300.0) as c:
        yield c


@pytest.mark.slow      # ~30 s: a compute worker starts and compiles the rendered kernels; the numbers are ~0.5 s
@pytest.mark.parametrize("where", ["controller", "requirements"])
def test_robust_box_with_a_fixed_filter(client, where):
    body = {"device": DEV, "requirements": {"uncertainty": UNC}, "verify": True}
    if where == "controller":
        body["controller"] = {"velocity_filter": LP50}
    else:
        body["requirements"]["velocity_filter"] = LP50
    r = client.post(PATH, json=body)
    assert r.status_code == 200, r.text
    out = r.json()
    assert out["status"] == "optimal" and out["robust"] is True
    assert out["rendered"]["kind"] == "low_pass" and out["rendered"]["cutoff_hz"] == 50
    worst = out["worst_case"]
    dev = Device(mass=worst["device"]["device.mass"], damping=worst["device"]["device.damping"], sample_time=0.001,
                 delay=worst["device"]["device.delay"])
    kcr = rendered_critical_stiffness(dev, out["damping"], rendering(LowPass(**LP50), 0.0, 0.001)).critical_stiffness
    assert kcr == pytest.approx(worst["critical_stiffness"], rel=1e-12)
    assert 20 * math.log10(kcr / out["stiffness"]) == pytest.approx(out["gain_margin_db"], abs=1e-9)
    assert out["gain_margin_db"] >= 6 - 1e-6
    v = out["verification"]
    assert v["verdict"] == "confirmed" and "interior search" in v["reason"]


@pytest.mark.parametrize("extra,loc_end", [
    ({"requirements": {"velocity_filter": {"kind": "low_pass", "design": True, "order": 1, "min_cutoff_hz": 5,
                                           "max_cutoff_hz": 200}}}, "design"),
    ({"requirements": {"passivity": True}, "controller": {"velocity_filter": LP50}}, "passivity"),
    ({"method": "grid", "controller": {"velocity_filter": LP50}}, "method"),
    ({"controller": {"velocity_filter": {"kind": "low_pass", "cutoff_hz": 200, "order": 1}},
      "requirements": {"uncertainty": {"device.sample_time": {"min": 0.001, "max": 0.004}}}}, "device.sample_time"),
])
def test_bad_combinations_are_422_naming_the_field(client, extra, loc_end):
    req = {"uncertainty": UNC, **extra.get("requirements", {})}
    body = {"device": DEV, **{k: v for k, v in extra.items() if k != "requirements"}, "requirements": req}
    r = client.post(PATH, json=body)
    assert r.status_code == 422, r.text
    err = r.json()["detail"][0]
    assert err["loc"][-1] == loc_end or ".".join(map(str, err["loc"])).endswith(loc_end), err


def test_the_robust_slice_of_a_rendered_wall_is_the_rendered_margin():
    """/v1/plots/robust's slice (service.plots_robust.margin_slice) with the filter: each cell is 20·log10 of the
    rendered K_cr over K, and the design's slice through its worst device never dips below the margin."""
    import numpy as np

    from optim.robust.box import UncertaintyBox
    from optim.robust.rendered_stiffness import robust_rendered_stiffness
    from optim.stiffness import StiffnessRequirements
    from service.plots_robust import margin_slice

    dev = Device(**DEV)
    spec = LowPass(**LP50)
    box = UncertaintyBox.from_ranges(dev, {k: (v["min"], v["max"]) for k, v in UNC.items()})
    d = robust_rendered_stiffness(dev, StiffnessRequirements(min_gain_margin_db=6), box, 0.0, spec)
    worst = np.array([d.worst_case["device"][p] for p in box.paths])
    xs, ys, margin = margin_slice(box, d.stiffness, d.damping, worst, "device.mass", "device.delay", 7, (spec, 0.0))
    assert margin.min() >= 6 - 1e-6
    point = worst.copy()
    point[0], point[2] = xs[3], ys[5]
    kcr = rendered_critical_stiffness(box.device_at(point), d.damping, rendering(spec, 0.0, 0.001)).critical_stiffness
    assert margin[5, 3] == pytest.approx(20 * math.log10(kcr / d.stiffness), abs=1e-12)
    today, _, plain = margin_slice(box, d.stiffness, d.damping, worst, "device.mass", "device.delay", 7)
    assert (plain > margin).all()      # today's wall's K_cr is higher: the slice is the filter's, not today's


@pytest.mark.slow      # a compute worker starts and compiles the rendered kernels (~30 s)
def test_robust_plot_of_a_rendered_wall(client):
    r = client.post("/v1/plots/robust?format=svg", json={"device": DEV, "controller": {"velocity_filter": LP50},
                                                         "requirements": {"uncertainty": UNC}, "points": 5})
    assert r.status_code == 200, r.text[:300]
    assert r.headers["content-type"].startswith("image/svg+xml")
