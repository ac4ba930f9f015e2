"""The typed client against a real server process: typed answers equal the numerics, errors map to the tree."""

from __future__ import annotations

import asyncio
import dataclasses

import httpx
import pytest

from clients import (
    APIError,
    AsyncZwidthClient,
    Plot,
    Retries,
    TransportError,
    ValidationFailed,
    ZwidthClient,
    calls,
    schemas,
)
from models.device import Device
from optim.stability.analysis import analyse_stability
from optim.stability.boundary import stability_boundary

from .conftest import has_route

pytestmark = pytest.mark.slow

DELAYED = {"preset": "lhifam", "delay": 0.001}
WALL = {"stiffness": 3500.0, "damping": 5.0}


class CountingTransport(httpx.HTTPTransport):
    """The real network transport, counting how many times a request was put on the wire."""

    def __init__(self) -> None:
        super().__init__()
        self.calls = 0

    def handle_request(self, request: httpx.Request) -> httpx.Response:
        self.calls += 1
        return super().handle_request(request)


@pytest.fixture(scope="module")
def zw(server):
    with ZwidthClient(server.url) as client:
        yield client


def test_health_and_presets_are_typed(zw):
    h = zw.health()
    assert (h.status, h.version) == ("ok", __import__("service.app").app.VERSION)
    presets = zw.presets()
    assert set(presets) == {"lhifam", "lhifam-reduced-pretension", "phantom-1.0"}
    assert all(isinstance(d, schemas.Device) for d in presets.values())
    # the server's resolved preset is the same device as the one built here from its name
    assert calls.device_json(presets["lhifam"]) == calls.device_json(Device(preset="lhifam"))


def test_stability_equals_the_numerics_exactly(zw):
    r = zw.stability(DELAYED, WALL)
    assert isinstance(r, schemas.StabilityResponse)
    direct = analyse_stability(Device(**DELAYED), WALL["stiffness"], WALL["damping"], "exact", 2000)
    # same function, same double-precision inputs through JSON (repr round-trips): bit-identical
    assert r.critical_stiffness == direct.critical_stiffness
    assert r.gain_margin_db == direct.gain_margin_db
    assert [c.frequency for c in r.crossovers] == [c["frequency"] if isinstance(c, dict) else c.frequency
                                                   for c in direct.crossovers]
    assert r.stable is True and r.method == "exact"


def test_a_device_model_is_sent_resolved(zw):
    """A Device built from a preset with its cable removed stays rigid on the server (preset not re-applied)."""
    rigid = Device(preset="lhifam", cable=None)
    r = zw.stability(rigid)
    assert r.rigid_critical_stiffness is None          # the server saw a rigid device
    assert r.critical_stiffness == pytest.approx(7000.756, rel=1e-6)   # chapter Table 3 rigid LHifAM, 76.90 dB


def test_boundary(zw):
    r = zw.boundary(DELAYED, points=12)
    assert isinstance(r, schemas.BoundaryResponse) and len(r.points) == 12
    direct = stability_boundary(Device(**DELAYED), None, 12)
    assert [p.critical_stiffness for p in r.points] == [p.critical_stiffness for p in direct.points]
    assert r.optimum.damping == direct.optimum.damping


def test_design_stiffness_keeps_its_margin(zw):
    r = zw.design_stiffness(DELAYED, {"min_gain_margin_db": 6})
    assert isinstance(r, schemas.StiffnessDesignResponse) and r.status == "optimal"
    # independent check through another endpoint: the designed wall's exact margin
    check = zw.stability(DELAYED, {"stiffness": r.stiffness, "damping": r.damping})
    assert check.gain_margin_db == pytest.approx(6.0, abs=1e-6)   # the design's margin constraint is active


def test_simulate_and_its_plot(zw):
    scene = {"experiment": "release", "duration": 0.5, "controller": {"stiffness": 3000}, "initial": {"position": 1e-3}}
    dev = {"preset": "lhifam", "cable": None}
    r = zw.simulate(dev, scene)
    assert isinstance(r, schemas.SimulateResponse) and r.verdict.state == "stable"
    plot = zw.plot_simulation(dev, scene, format="svg")
    assert isinstance(plot, Plot) and plot.media_type == "image/svg+xml" and b"<svg" in plot.content[:500]


@pytest.mark.slow
def test_async_client_gives_the_same_answers(server, zw):
    async def run():
        async with AsyncZwidthClient(server.url) as az:
            return await asyncio.gather(az.stability(DELAYED, WALL), az.boundary(DELAYED, points=5))
    s, b = asyncio.run(run())
    assert s.model_dump(exclude={"elapsed_ms"}) == zw.stability(DELAYED, WALL).model_dump(exclude={"elapsed_ms"})
    assert b.points == zw.boundary(DELAYED, points=5).points


@pytest.mark.slow
def test_422_becomes_validation_failed_naming_the_field(server):
    counter = CountingTransport()
    with ZwidthClient(server.url, transport=counter) as zw, pytest.raises(ValidationFailed) as info:
        zw.stability({"mass": 5.4, "damping": 3.5, "delay": -0.001})
    exc = info.value
    assert exc.status == 422 and exc.fields == ["device.delay"]
    assert "device.delay" in str(exc) and "greater than or equal to 0" in str(exc)
    assert isinstance(exc, APIError) and isinstance(exc, ValueError)
    assert counter.calls == 1                         # never retried


@pytest.mark.slow
def test_a_numerics_rule_is_named_too(server):
    """A 422 from a model rule (the cost limit) names the field in its location or its message.

    (Builds whose error handler moves "delay: …" into the location report ``device.delay``; older ones
    report ``device`` with the message starting "delay:"; the client passes on what the server said.)
    """
    with ZwidthClient(server.url) as zw, pytest.raises(ValidationFailed) as info:
        zw.stability({"mass": 5.4, "damping": 3.5, "delay": 20.0})   # 20,000 samples > MAX_DELAY_SAMPLES
    field, msg = info.value.fields[0], info.value.errors[0]["msg"]
    assert field == "device.delay" or (field == "device" and "delay:" in msg)
    assert "10000 samples" in msg


@pytest.mark.slow
def test_404_is_an_api_error_and_not_retried(server):
    counter = CountingTransport()
    with ZwidthClient(server.url, transport=counter, retries=Retries(attempts=4, backoff=0.0)) as zw:
        bad = dataclasses.replace(__import__("clients.calls").calls.health(), path="/v1/no-such-thing")
        with pytest.raises(APIError) as info:
            zw.send(bad)
    assert info.value.status == 404 and not isinstance(info.value, ValidationFailed)
    assert counter.calls == 1


def test_connection_refused_is_retried_then_raised(dead_url):
    counter = CountingTransport()
    with ZwidthClient(dead_url, transport=counter, retries=Retries(attempts=3, backoff=0.01)) as zw:
        with pytest.raises(TransportError) as info:
            zw.stability(DELAYED)
    assert counter.calls == 3 and info.value.attempts == 3
    assert isinstance(info.value, ConnectionError)
    assert "ConnectError" in str(info.value) and dead_url in info.value.url


@pytest.mark.skipif(not has_route("/v1/analysis/force-feedforward"),
                    reason="POST /v1/analysis/force-feedforward is not in this build yet (branch inertia)")
def test_force_feedforward(zw):
    from optim.transparency.feedforward import critical_force_gain

    r = zw.force_feedforward({"preset": "lhifam", "cable": None})
    assert isinstance(r, schemas.ForceFeedforwardResponse)
    assert r.critical_force_gain == critical_force_gain(Device(preset="lhifam", cable=None)).critical_force_gain


@pytest.mark.skipif(not has_route("/v1/design/inertia"),
                    reason="POST /v1/design/inertia is not in this build yet (branch inertia)")
def test_design_inertia(zw):
    r = zw.design_inertia({"preset": "lhifam", "cable": None}, {"min_gain_margin_db": 6, "pareto_points": 3})
    assert isinstance(r, schemas.InertiaResponse) and r.status == "optimal"
    ff = zw.force_feedforward({"preset": "lhifam", "cable": None},
                              {"cutoff_hz": r.filter_cutoff_hz, "order": r.filter_order})
    assert r.force_gain == pytest.approx(ff.critical_force_gain / 10 ** (6 / 20), rel=1e-6)


@pytest.mark.slow
@pytest.mark.skipif(not has_route("/v1/plots/boundary"),
                    reason="POST /v1/plots/boundary and /v1/plots/bode are not in this build yet (branch service)")
def test_plots_boundary_and_bode(zw):
    png = zw.plot_boundary(DELAYED, points=10)
    assert png.media_type == "image/png" and png.content[:8] == b"\x89PNG\r\n\x1a\n"
    svg = zw.plot_bode(DELAYED, WALL, points=50, format="svg")
    assert svg.media_type == "image/svg+xml" and b"<svg" in svg.content[:500]
