"""``zwidth robust …`` (clients/robust_cli.py) through ``--local``: the service's own app in this process.

The answers are the service's (checked against the numerics in tests/optim/robust and
tests/optim/test_hardware*.py); here: the requests the commands build, their output and exit codes."""

import json

import pytest
from typer.testing import CliRunner

from clients.cli import app as cli
from clients.robust_cli import parse_range

pytestmark = pytest.mark.slow


def run(*args: str, code: int = 0):
    r = CliRunner().invoke(cli, ["robust", *args, "--local"])
    assert r.exit_code == code, r.output
    return r


def test_robust_stiffness_json_and_table():
    r = run("stiffness", "lhifam", "--rigid", "--range", "device.delay=0:0.001", "--json")
    body = json.loads(r.output)
    assert body["robust"] and body["status"] == "optimal"
    assert body["worst_case"]["gain_margin_db"] >= 6 - 1e-6
    assert body["worst_case"]["device"]["device.delay"] == pytest.approx(0.001)   # delay only lowers K_cr
    table = run("stiffness", "lhifam", "--rigid", "--range", "device.delay=0:0.001").output
    assert "robust stiffness design" in table and "device.delay = 0.001" in table


def test_hardware_force_gain_and_apparent_mass():
    body = json.loads(run("hardware", "lhifam", "--rigid", "--free", "delay", "--stiffness", "2e5",
                          "--force-gain", "9", "--points", "9", "--json").output)
    assert body["status"] == "optimal" and body["limiting_target"] == "force_gain"
    assert body["controller"]["force_gain_margin_db"] == pytest.approx(6.0, abs=1e-6)
    body = json.loads(run("hardware", "lhifam", "--rigid", "--free", "mass", "--apparent-mass", "0.5",
                          "--points", "9", "--json").output)
    assert body["limiting_target"] == "apparent_mass" and body["direction"] == "max"
    assert "hardware design" in run("hardware", "lhifam", "--rigid", "--free", "delay", "--force-gain", "5",
                                    "--points", "9").output


def test_infeasible_is_exit_1_and_bad_input_exit_2():
    r = run("hardware", "lhifam", "--rigid", "--free", "delay", "--stiffness", "1e12", "--points", "9", "--json",
            code=1)
    assert json.loads(r.output)["status"] == "infeasible"
    r = run("hardware", "lhifam", "--rigid", "--free", "delay", "--force-gain", "5", "--apparent-mass", "1",
            "--points", "9", code=2)
    assert "target" in r.output
    r = run("stiffness", "lhifam", "--range", "device.wheels=1:2", code=2)
    assert "device.wheels" in r.output
    assert "--range" in run("stiffness", "lhifam", code=2).output
    assert "--free" in run("hardware", "lhifam", code=2).output


def test_plots(tmp_path):
    png = tmp_path / "slice.png"
    run("plot", "lhifam", "--rigid", "--range", "device.mass=4:7", "--range", "device.delay=0:0.001",
        "--points", "5", "-o", str(png))
    assert png.read_bytes().startswith(b"\x89PNG")
    svg = tmp_path / "hw.svg"
    run("plot", "lhifam", "--rigid", "--free", "delay", "--stiffness", "2e5", "--points", "9", "-o", str(svg))
    assert b"<svg" in svg.read_bytes()[:400]
    assert "either" in run("plot", "lhifam", "-o", str(png), code=2).output


def test_parse_range():
    assert parse_range("device.mass=4:7") == ("device.mass", {"min": 4.0, "max": 7.0})
    import typer
    with pytest.raises(typer.Exit):
        parse_range("device.mass=4")


def test_zwidth_client_design_hardware_in_process():
    """ZwidthClient.design_hardware / plot_hardware through the app itself (clients.local: no socket)."""
    from clients import ZwidthClient
    from clients.local import LocalTransport
    from clients.schemas import HardwareDesignResponse

    with ZwidthClient(transport=LocalTransport()) as zw:
        r = zw.design_hardware({"preset": "lhifam", "cable": None}, "delay", force_gain=5.0, points=9)
        assert isinstance(r, HardwareDesignResponse) and r.limiting_target == "force_gain"
        assert r.controller.force_gain_margin_db == pytest.approx(6.0, abs=1e-6)
        png = zw.plot_hardware({"preset": "lhifam", "cable": None}, "delay", force_gain=5.0, points=9)
        assert png.media_type == "image/png" and png.content.startswith(b"\x89PNG")
        req = {"uncertainty": {"device.mass": {"min": 4, "max": 7}}}
        svg = zw.plot_robust({"preset": "lhifam", "cable": None}, req, points=5, format="svg")
        assert svg.media_type == "image/svg+xml"


def _documented_hardware_examples() -> list[tuple[str, str]]:
    """(command, documented status) of every `zwidth robust hardware` example in docs/robust.md and
    docs/clients.md."""
    import re

    from .conftest import ROOT
    out = []
    robust = (ROOT / "docs" / "robust.md").read_text(encoding="utf-8")
    for line in robust.splitlines():
        m = re.match(r"(zwidth robust hardware [^#]*?)\s+# (optimal|infeasible)", line)
        if m:
            out.append((m.group(1), m.group(2)))
    clients = (ROOT / "docs" / "clients.md").read_text(encoding="utf-8")
    m = re.search(r"`(zwidth robust hardware [^`]*)`.*?answers `(optimal|infeasible)`", clients, flags=re.DOTALL)
    assert m, "docs/clients.md: the hardware example and its documented status"
    out.append((m.group(1), m.group(2)))
    documented = dict(out)            # one run per command; the same command must have one status
    assert len(documented) == len(set(out)) and len(documented) >= 2
    return sorted(documented.items())


@pytest.mark.slow
@pytest.mark.parametrize("command,status", _documented_hardware_examples())
def test_documented_hardware_examples_run_as_documented(command, status, monkeypatch):
    """Issue 17: each documented example answers its documented status (exit 1 when infeasible), and an
    infeasible one names what binds, not the free parameter at its bound (zero delay).  The request budget is
    raised: each takes ~6 s on a quiet machine, and the 30 s default was passed once on a machine loaded 4×
    (a 503 there is the budget working, not the documented answer this test is about)."""
    monkeypatch.setenv("ZWIDTH_REQUEST_TIMEOUT", "300")
    args = command.split()[2:]
    body = json.loads(run(*args, "--json", code=0 if status == "optimal" else 1).output)
    assert body["status"] == status
    if status == "infeasible":
        assert body["best_value"] == 0.0 and "physical bound delay = 0" in body["range_source"]
        assert body["limiting_effect"].startswith("sampling")
    else:
        assert body["limiting_target"] == "stiffness" and body["value"] == pytest.approx(1.768e-3, rel=1e-3)


def test_hardware_scan_range():
    """--scan MIN:MAX is the request's range (scanned as given); a malformed one is a usage error (exit 2)."""
    body = json.loads(run("hardware", "lhifam", "--rigid", "--free", "delay", "--stiffness", "2e5", "--points", "9",
                          "--scan", "0:0.01", "--json").output)
    assert body["range_source"] == "request" and body["scanned_range"] == [0, 0.01]
    assert "--scan" in run("hardware", "lhifam", "--free", "delay", "--stiffness", "2e5", "--scan", "0.01",
                           code=2).output
    assert "range.min" in run("hardware", "lhifam", "--free", "delay", "--stiffness", "2e5", "--scan", "0.01:0.001",
                              code=2).output


@pytest.mark.slow
def test_verify_on_robust_stiffness_and_hardware():
    """--verify: a robust wall checked at every corner (one row per device), the hardware design's controller."""
    body = json.loads(run("stiffness", "lhifam", "--rigid", "--range", "device.delay=0:0.001", "--verify",
                          "--json").output)
    v = body["verification"]
    assert v["verdict"] == "confirmed" and [p["kind"] for p in v["points"]] == ["corner", "corner"]
    table = run("stiffness", "lhifam", "--rigid", "--range", "device.delay=0:0.001", "--verify").output
    assert "verified corner" in table and "device.delay = 0.001: confirmed" in table
    body = json.loads(run("hardware", "lhifam", "--rigid", "--free", "delay", "--stiffness", "2e5",
                          "--force-gain", "9", "--points", "9", "--verify", "--json").output)
    assert body["status"] == "optimal" and body["verification"]["verdict"] == "confirmed"
