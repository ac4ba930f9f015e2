"""``zwidth study run|status|results|cancel`` against the app (in-process, temp store)."""

from __future__ import annotations

import contextlib
import csv
import io
import json

import pytest
from fastapi.testclient import TestClient
from typer.testing import CliRunner

from clients import cli_study
from clients.cli import app as cli
from service.app import create_app
from service.settings import Settings
from tests.service.studies_helpers import small_study


@pytest.fixture()
def zwidth(tmp_path, monkeypatch):
    monkeypatch.setenv("ZWIDTH_STUDY_WORKERS", "1")
    with TestClient(create_app(Settings(database_url=f"sqlite:///{tmp_path / 's.db'}"))) as client:
        monkeypatch.setattr(cli_study, "_client", lambda server: contextlib.nullcontext(client))
        runner = CliRunner()
        yield lambda *args, **kw: runner.invoke(cli, ["study", *args], **kw)


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


def test_run_reports_422_with_the_field(zwidth, tmp_path):
    req = tmp_path / "bad.json"
    req.write_text(json.dumps({**small_study(), "sweep": {"device.wheels": [1]}}))
    r = zwidth("run", str(req))
    assert r.exit_code == 2 and "sweep.device.wheels" in r.output


def test_no_service_is_exit_code_3(tmp_path):
    req = tmp_path / "study.json"
    req.write_text(json.dumps(small_study(3)))
    import socket
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # nothing listens here once closed
    r = CliRunner().invoke(cli, ["study", "run", str(req), "--url", f"http://127.0.0.1:{port}"])
    assert r.exit_code == 3 and "did not answer" in r.output
