"""``--verify`` on the CLI and ``verify=True`` in the Python client (in process: --local / the ASGI app)."""

from __future__ import annotations

import json

from typer.testing import CliRunner

from clients.cli import app

runner = CliRunner()


def test_analyze_verify_local():
    r = runner.invoke(app, ["analyze", "--local", "--set", "device.mass=5.4", "--set", "device.damping=3.5",
                            "--set", "device.delay=0.002", "--verify", "--json"])
    assert r.exit_code == 0, r.stdout
    v = json.loads(r.stdout)["verification"]
    assert v["verdict"] == "confirmed" and v["radius_below"] < 1 < v["radius_above"]
    human = runner.invoke(app, ["analyze", "--local", "--set", "device.mass=5.4", "--set", "device.damping=3.5",
                                "--verify"])
    assert "verification" in human.stdout and "confirmed" in human.stdout


def test_client_passes_verify_and_exposes_the_record():
    from clients.client import ZwidthClient
    from clients.local import LocalTransport

    with ZwidthClient("http://local", transport=LocalTransport()) as zw:
        plain = zw.stability({"mass": 5.4, "damping": 3.5})
        assert plain.verification is None
        checked = zw.stability({"mass": 5.4, "damping": 3.5}, verify=True)
        assert checked.verification is not None and checked.verification.verdict == "confirmed"


def test_feedforward_verify_local():
    r = runner.invoke(app, ["feedforward", "lhifam", "--cutoff-hz", "30", "--local", "--verify", "--json"])
    assert r.exit_code == 0, r.stdout
    assert json.loads(r.stdout)["verification"]["verdict"] == "confirmed"


def test_the_documented_example_runs():
    import re
    import shlex
    from pathlib import Path

    doc = (Path(__file__).resolve().parents[2] / "docs" / "verification.md").read_text(encoding="utf-8")
    (cmd,) = re.findall(r"```\n(zwidth .*?)\n```", doc, flags=re.DOTALL)
    r = runner.invoke(app, shlex.split(cmd)[1:] + ["--json"])
    assert r.exit_code == 0, r.stdout
    assert json.loads(r.stdout)["verification"]["verdict"] == "confirmed"
