"""``zwidth identify data.csv`` against the real server process, and --local beside it (same JSON)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from clients.cli import app
from models.device import Device
from optim.identification.models import response

from .conftest import without_timings

runner = CliRunner()


@pytest.fixture(autouse=True)
def _env(server, monkeypatch):
    monkeypatch.setenv("ZWIDTH_URL", server.url)
    monkeypatch.delenv("ZWIDTH_API_TOKEN", raising=False)


def _run(*args: str, code: int = 0):
    result = runner.invoke(app, list(args))
    assert result.exit_code == code, (result.exit_code, result.stdout, result.stderr, result.exception)
    return result


@pytest.fixture
def response_csv(tmp_path):
    w = np.geomspace(6.0, 2000.0, 30)
    h = response(Device(mass=5.4, damping=3.5, delay=0.0015), w, "continuous")
    path = tmp_path / "sweep.csv"
    path.write_text("frequency,real,imag\n" + "".join(f"{a!r},{b!r},{c!r}\n" for a, b, c in
                                                       zip(w.tolist(), h.real.tolist(), h.imag.tolist())))
    return path


@pytest.mark.slow
def test_identify_response_local_and_remote(response_csv, tmp_path):
    remote = json.loads(_run("identify", str(response_csv), "--model", "rigid", "--json").stdout)
    local = json.loads(_run("identify", str(response_csv), "--model", "rigid", "--json", "--local").stdout)
    assert without_timings(local) == without_timings(remote)
    assert remote["status"] == "identified" and remote["device"]["mass"] == pytest.approx(5.4, rel=1e-9)
    plot = tmp_path / "fit.svg"
    human = _run("identify", str(response_csv), "--model", "rigid", "--plot", str(plot)).stdout
    assert "identified" in human and "mass" in human and plot.read_bytes().lstrip().startswith(b"<")


@pytest.mark.slow
def test_identify_time_series_with_known_delay(tmp_path):
    from tests.optim.identification.cases import record

    d = record("rigid", 0.0013)
    path = tmp_path / "run.csv"
    path.write_text("time,force,position\n" + "".join(
        f"{k * 0.001:.6f},{u!r},{y!r}\n" for k, (u, y) in enumerate(zip(d.force.tolist(), d.position.tolist()))))
    body = json.loads(_run("identify", str(path), "--model", "rigid", "--known", "delay=0.0013", "--json").stdout)
    assert body["parameters"]["delay"] == {"value": 0.0013, "std_error": 0.0, "interval": [0.0013, 0.0013]}
    assert body["parameters"]["mass"]["value"] == pytest.approx(5.4, rel=0.01)


@pytest.mark.slow
def test_bad_files_and_data(tmp_path, response_csv):
    bad = tmp_path / "bad.csv"
    bad.write_text("t,f,x\n0,1,2\n")
    assert "header must name the columns" in _run("identify", str(bad), code=2).stderr
    uneven = tmp_path / "uneven.csv"
    uneven.write_text("time,force,position\n0,1,0\n0.001,2,0\n0.003,1,0\n")
    assert "uniformly sampled" in _run("identify", str(uneven), code=2).stderr
    # a 422 from the service (too few points for the cable model) is a usage error naming the field
    few = tmp_path / "few.csv"
    few.write_text("\n".join(response_csv.read_text().splitlines()[:8]) + "\n")
    assert "data.frequency" in _run("identify", str(few), "--model", "cable", code=2).stderr
    # a failed fit answers 1
    _run("identify", str(response_csv), "--model", "cable", code=1)
