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


def test_parse_range():
    assert robust_cli.parse_range("device.mass=4:7") == ("device.mass", (4.0, 7.0))
    with pytest.raises(Exception):
        robust_cli.parse_range("device.mass=4")
