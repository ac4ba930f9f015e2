"""The Python client's and the CLI's plot_boundary with a rendered wall (issue 30): the controller goes in the body as
POST /v1/plots/boundary takes it (the route's numbers: tests/service/test_plot_boundary_rendered.py)."""

from __future__ import annotations

import json

import httpx

from clients.cli import app

from .test_client_mock import client

PNG = b"\x89PNG\r\n\x1a\nrest"
LP50 = {"kind": "low_pass", "cutoff_hz": 50.0, "order": 1}


def test_client_sends_the_controller():
    zw, rec = client(lambda r: httpx.Response(200, content=PNG, headers={"content-type": "image/png"}))
    zw.plot_boundary({"preset": "lhifam"}, {"mass": -0.5, "velocity_filter": LP50}, points=10)
    assert json.loads(rec.requests[0].content) == {"device": {"preset": "lhifam"}, "points": 10,
                                                   "controller": {"mass": -0.5, "velocity_filter": LP50}}
    zw.plot_boundary({"preset": "lhifam"}, points=10)     # today's request: no controller key
    assert json.loads(rec.requests[1].content) == {"device": {"preset": "lhifam"}, "points": 10}


def test_cli_builds_the_controller(monkeypatch, tmp_path):
    seen = {}

    def fake(self, device, controller=None, **kw):
        seen.update(device=device, controller=controller, **kw)
        from clients.calls import Plot
        return Plot(PNG, "image/png")
    monkeypatch.setattr("clients.client.ZwidthClient.plot_boundary", fake)
    from typer.testing import CliRunner
    out = tmp_path / "b.png"
    r = CliRunner().invoke(app, ["plot", "boundary", "lhifam", "--velocity-filter", "low_pass:50:1",
                                 "--virtual-mass", "-0.5", "-o", str(out)])
    assert r.exit_code == 0, r.output
    assert seen["controller"] == {"mass": -0.5, "velocity_filter": LP50}
