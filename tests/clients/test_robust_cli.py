"""clients/robust_cli.py against the app: httpx.post is replaced by the app's TestClient (no network)."""

import warnings

import httpx
import pytest

with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    from fastapi.testclient import TestClient

from clients import robust_cli
from service.app import create_app


@pytest.fixture()
def wired(monkeypatch):
    client = TestClient(create_app())

    def post(url, json=None, params=None, timeout=None):
        return client.post(url.replace(robust_cli.DEFAULT_URL, ""), json=json, params=params)

    monkeypatch.setattr(httpx, "post", post)
    return client


def test_robust_stiffness_and_hardware(wired):
    dev = {"preset": "lhifam", "cable": None}
    out = robust_cli.robust_stiffness(dev, {"device.delay": (0.0, 0.001)})
    assert out["robust"] and out["status"] == "optimal" and out["gain_margin_db"] >= 6 - 1e-6
    hw = robust_cli.hardware(dev, "delay", 2e5, points=9)
    assert hw["status"] == "optimal" and hw["direction"] == "max"
    png = robust_cli.plot("hardware", {"device": dev, "target": {"stiffness": 2e5}, "free": "delay", "points": 9})
    assert png.startswith(b"\x89PNG")


def test_hardware_force_feedforward_targets(wired):
    dev = {"preset": "lhifam", "cable": None}
    hw = robust_cli.hardware(dev, "delay", 2e5, points=9, force_gain=9.0)
    assert hw["status"] == "optimal" and hw["limiting_target"] == "force_gain"
    assert hw["controller"]["force_gain_margin_db"] == pytest.approx(6.0, abs=1e-6)
    hw = robust_cli.hardware(dev, "mass", points=9, apparent_mass=0.5)
    assert hw["limiting_target"] == "apparent_mass" and hw["direction"] == "max"


def test_hardware_command_force_gain(wired):
    import json

    from typer.testing import CliRunner

    out = CliRunner().invoke(robust_cli.robust_app, ["hardware", "--free", "delay", "--rigid", "--force-gain", "5",
                                                     "--points", "9"])
    assert out.exit_code == 0, out.output
    body = json.loads(out.output)
    assert body["limiting_target"] == "force_gain" and body["controller"]["force_gain"] == 5.0
    assert "curve" not in body


def test_parse_range():
    assert robust_cli.parse_range("device.mass=4:7") == ("device.mass", (4.0, 7.0))
    with pytest.raises(Exception):
        robust_cli.parse_range("device.mass=4")


def test_zwidth_client_design_hardware_in_process():
    """ZwidthClient.design_hardware / plot_hardware through the app itself (clients.local: no socket)."""
    from clients import ZwidthClient
    from clients.local import LocalTransport
    from service.schemas.design_hardware import HardwareDesignResponse

    with ZwidthClient(transport=LocalTransport()) as zw:
        r = zw.design_hardware({"preset": "lhifam", "cable": None}, "delay", force_gain=5.0, points=9)
        assert isinstance(r, HardwareDesignResponse) and r.limiting_target == "force_gain"
        assert r.controller.force_gain_margin_db == pytest.approx(6.0, abs=1e-6)
        png = zw.plot_hardware({"preset": "lhifam", "cable": None}, "delay", force_gain=5.0, points=9)
        assert png.media_type == "image/png" and png.content.startswith(b"\x89PNG")
