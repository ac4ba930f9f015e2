"""POST /v1/plots/boundary with a controller (issue 30): the figure draws the rendered boundary K_cr(B) of the velocity
filter and virtual mass (optim.stability.boundary with the Rendering, the numbers of POST /v1/analysis/boundary), its
title names them, and bad filters are 422s under controller. as the analysis route's."""

from __future__ import annotations

import numpy as np
import pytest

import service.plots as plots
from models.device import Device
from models.velocity_filter import LowPass, rendering
from optim.stability.boundary import stability_boundary
from tests.service.conftest import make_client

DEV = {"mass": 5.4, "damping": 3.5, "sample_time": 0.001, "delay": 0.0005}


@pytest.fixture(scope="module")
def client():
    with make_client(request_timeout=300.0) as c:
        yield c


def test_the_figure_draws_the_rendered_boundary(monkeypatch):
    device = Device(**DEV)
    r = rendering(LowPass(kind="low_pass", cutoff_hz=50, order=1), -0.5, device.sample_time)
    drawn = {}
    monkeypatch.setattr(plots, "render", lambda fig, fmt: drawn.setdefault("fig", fig) and b"")
    plots.boundary_plot(device, None, 12, "svg", r)
    fig = drawn["fig"]
    line = next(ln for ln in fig.axes[0].get_lines() if ln.get_gid() == "boundary")
    filtered = stability_boundary(device, None, 12, r)
    assert np.array_equal(line.get_xdata(), [p.damping for p in filtered.points])
    assert np.array_equal(line.get_ydata(), [p.critical_stiffness for p in filtered.points], equal_nan=True)
    today = stability_boundary(device, None, 12)
    assert filtered.max_stable_damping != today.max_stable_damping          # the filter moved the curve
    title = fig.axes[0].get_title()
    assert "low pass 50 Hz, order 1" in title and "virtual mass M = -0.5" in title


@pytest.mark.parametrize("controller,loc", [
    ({"velocity_filter": {"kind": "low_pass", "cutoff_hz": 500, "order": 1}}, "cutoff_hz"),
    ({"velocity_filter": {"kind": "moving_average", "samples": 0}}, "samples"),
    ({"velocity_filter": {"kind": "low_pass", "cutoff_hz": 50, "order": 3}}, "order"),
    ({"stiffness": 10.0}, "stiffness"),
])
def test_bad_controller_is_422_naming_the_field(client, controller, loc):
    r = client.post("/v1/plots/boundary", json={"device": DEV, "controller": controller, "points": 5})
    assert r.status_code == 422, r.text[:300]
    err = r.json()["detail"][0]
    assert err["loc"][0] == "body" and "controller" in err["loc"] and err["loc"][-1] == loc, err


@pytest.mark.slow      # a compute worker starts and compiles the rendered kernels (~30 s)
def test_route_answers_an_image_of_the_rendered_boundary(client):
    r = client.post("/v1/plots/boundary?format=svg", json={
        "device": DEV, "points": 8, "controller": {"velocity_filter": {"kind": "low_pass", "cutoff_hz": 50,
                                                                       "order": 1}}})
    assert r.status_code == 200, r.text[:300]
    assert r.headers["content-type"].startswith("image/svg+xml") and b"low pass 50 Hz" in r.content
