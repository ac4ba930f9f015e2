"""``zwidth study run|status|results|cancel`` against the app (in-process, temp store)."""

from __future__ import annotations

import csv
import io
import json

import pytest
from fastapi.testclient import TestClient
from typer.testing import CliRunner

from clients import ZwidthClient, cli_study
from clients.cli import app as cli
from service.app import create_app
from service.settings import Settings
from tests.service.studies_helpers import small_study


@pytest.fixture()
def zwidth(tmp_path, monkeypatch):
    monkeypatch.setenv("ZWIDTH_STUDY_WORKERS", "1")
    with TestClient(create_app(Settings(database_url=f"sqlite:///{tmp_path / 's.db'}"))) as client:
        # the CLI's own ZwidthClient, sending through the in-process app's transport
        monkeypatch.setattr(cli_study, "_client",
                            lambda url, token: ZwidthClient("http://testserver", transport=client._transport))
        runner = CliRunner()
        yield lambda *args, **kw: runner.invoke(cli, ["study", *args], **kw)


@pytest.mark.slow
def test_run_status_results(zwidth, tmp_path):
    req = tmp_path / "study.json"
    req.write_text(json.dumps(small_study(3)))
    r = zwidth("run", str(req), "--poll", "0.1")
    assert r.exit_code == 0, r.output
    sid = r.output.split()[1].rstrip(":")
    assert "6 points" in r.output and "done: 6/6 points, 0 failed" in r.output
    r = zwidth("status", sid, "--json")
    assert json.loads(r.output)["status"] == "done"
    assert sid in zwidth("status").output
    r = zwidth("results", sid, "--format", "csv")
    rows = list(csv.DictReader(io.StringIO(r.output)))
    assert [int(x["index"]) for x in rows] == list(range(6))
    out = tmp_path / "r.parquet"
    assert zwidth("results", sid, "--format", "parquet", "--out", str(out)).exit_code == 0
    assert out.read_bytes()[:4] == b"PAR1"


@pytest.mark.slow
def test_run_reports_422_with_the_field(zwidth, tmp_path):
    req = tmp_path / "bad.json"
    req.write_text(json.dumps({**small_study(), "sweep": {"device.wheels": [1]}}))
    r = zwidth("run", str(req))
    assert r.exit_code == 2 and "sweep.device.wheels" in r.output


@pytest.mark.slow
def test_no_service_is_exit_code_3(tmp_path):
    req = tmp_path / "study.json"
    req.write_text(json.dumps(small_study(3)))
    import socket
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # nothing listens here once closed
    r = CliRunner().invoke(cli, ["study", "run", str(req), "--url", f"http://127.0.0.1:{port}"])
    assert r.exit_code == 3 and "no answer from the service" in r.output


@pytest.mark.slow
def test_cancel_and_purge(zwidth, tmp_path):
    req = tmp_path / "study.json"
    req.write_text(json.dumps(small_study(3)))
    sid = zwidth("run", str(req), "--no-wait").output.split()[1].rstrip(":")
    r = zwidth("cancel", sid)
    assert r.exit_code == 0 and sid in r.output            # cancelled, or done already: both are answers
    r = zwidth("cancel", sid, "--purge")
    assert r.exit_code == 0 and "purged" in r.output
    r = zwidth("status", sid)
    assert r.exit_code == 3 and "404" in r.output          # gone


@pytest.mark.slow
def test_unreadable_request_is_usage(zwidth, tmp_path):
    req = tmp_path / "bad.json"
    req.write_text("{not json")
    r = zwidth("run", str(req))
    assert r.exit_code == 2 and "cannot read" in r.output


def test_progress_bar_shows_points_rate_and_eta():
    """The bar's fields come from the service's own rate and ETA (points per second, seconds left)."""
    from types import SimpleNamespace

    fields = cli_study.progress_fields(SimpleNamespace(rate=12.345, eta_s=75.4))
    assert fields == {"rate": "12.3 pts/s", "eta": "ETA 1:15"}
    assert cli_study.progress_fields(SimpleNamespace(rate=None, eta_s=None)) == {"rate": "— pts/s", "eta": "ETA —"}
    assert cli_study.progress_fields(SimpleNamespace(rate=0.25, eta_s=3725))["eta"] == "ETA 1:02:05"


@pytest.mark.slow
def test_run_bar_names_points(zwidth, tmp_path):
    req = tmp_path / "study.json"
    req.write_text(json.dumps(small_study(3)))
    r = zwidth("run", str(req), "--poll", "0.05")
    assert r.exit_code == 0, r.output
    assert "points," in r.output and "pts/s" in r.output and "ETA" in r.output, r.output
