"""/v1/studies over HTTP (in-process app, temp SQLite store, local process pool)."""

from __future__ import annotations

import csv
import io
import json
import math
import sys

import pyarrow.parquet as pq
import pytest
from fastapi.testclient import TestClient

from optim.studies import problems as optim_studies
from service.app import create_app
from service.settings import Settings
from tests.reference_values import CASES
from tests.service.studies_helpers import LHIFAM_RIGID, small_study, wait_finished


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    db = tmp_path_factory.mktemp("studies") / "store.db"
    mp = pytest.MonkeyPatch()
    mp.setenv("ZWIDTH_STUDY_WORKERS", "2")
    mp.setenv("ZWIDTH_STUDY_CHUNK_SIZE", "4")
    with TestClient(create_app(Settings(database_url=f"sqlite:///{db}"))) as c:
        yield c
    mp.undo()


def _get(client):
    return lambda sid: client.get(f"/v1/studies/{sid}").json()


@pytest.fixture(scope="module")
def finished(client):
    r = client.post("/v1/studies", json=small_study(6))
    assert r.status_code == 202, r.text
    body = r.json()
    assert body["points"] == 12 and body["status"] == "queued"
    st = wait_finished(_get(client), body["id"])
    assert st["status"] == "done", st
    return body["id"]


def _all_json(client, sid: str, limit: int) -> list[dict]:
    rows, offset = [], 0
    while offset is not None:
        page = client.get(f"/v1/studies/{sid}/results", params={"offset": offset, "limit": limit}).json()
        rows += page["rows"]
        offset = page["next_offset"]
    return rows


@pytest.mark.slow
def test_status_progress_and_rate(client, finished):
    st = client.get(f"/v1/studies/{finished}").json()
    assert (st["done"], st["total"], st["failed"], st["progress"]) == (12, 12, 0, 1.0)
    assert st["rate"] > 0 and st["eta_s"] == 0.0
    assert st["sweep"] == ["device.delay", "requirements.damping"]
    assert finished in [s["id"] for s in client.get("/v1/studies").json()["studies"]]


@pytest.mark.slow
def test_results_are_the_analysis_at_each_point(client, finished):
    rows = _all_json(client, finished, limit=5)  # three pages
    assert [r["index"] for r in rows] == list(range(12))
    for r in rows:
        t, d, b = LHIFAM_RIGID["sample_time"], r["device.delay"], r["requirements.damping"]
        # eq. 10 by hand, independent of optim: (b + B)/(T/2 + t_d)
        assert r["linear_estimate"] == pytest.approx((3.5 + b) / (t / 2 + d), rel=1e-14)  # one rounding
        assert r["stiffness"] == 1500.0 and r["damping"] == b and r["error"] is None
        # exact K_cr stays within the chapter's linearisation error of eq. 10 (δ, β small here)
        assert r["critical_stiffness"] == pytest.approx(r["linear_estimate"], rel=0.02)
        assert r["gain_margin_db"] == pytest.approx(20 * math.log10(r["critical_stiffness"] / 1500.0), rel=1e-12)
    first = rows[0]
    case = CASES["table3-lhifam-rigid"]  # chapter Table 3: 76.9 dB at delay 0, B = 0
    assert (first["device.delay"], first["requirements.damping"]) == (0.0, 0.0)
    assert 20 * math.log10(first["critical_stiffness"]) == pytest.approx(case["printed"], abs=case["tolerance_db"])


@pytest.mark.slow
def test_exports_round_trip(client, finished):
    rows = _all_json(client, finished, limit=1000)
    cols = client.get(f"/v1/studies/{finished}/results").json()["columns"]
    r = client.get(f"/v1/studies/{finished}/results", params={"format": "csv"})
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/csv")
    back = list(csv.DictReader(io.StringIO(r.text)))
    assert list(back[0]) == cols and len(back) == len(rows)

    def parse(text: str, like):
        if text == "":
            return None
        if isinstance(like, bool):
            return {"true": True, "false": False}[text]
        return type(like)(text) if like is not None else text
    for want, got in zip(rows, back):
        assert {k: parse(got[k], want[k]) for k in cols} == want  # floats exactly (repr)

    r = client.get(f"/v1/studies/{finished}/results", params={"format": "parquet"})
    assert r.status_code == 200
    table = pq.read_table(io.BytesIO(r.content))
    assert table.column_names == cols
    assert table.to_pylist() == rows


@pytest.mark.parametrize("change, loc", [
    ({"sweep": {"device.wheels": [1.0]}}, ["body", "sweep", "device.wheels"]),
    ({"sweep": {"device.delay": []}}, ["body", "sweep", "device.delay"]),
    ({"sweep": {"device.delay": {"start": 0, "stop": 1e-3, "num": 3, "scale": "cubic"}}},
     ["body", "sweep", "device.delay"]),
    ({"sweep": {"device.delay": {"start": 0, "stop": 1e-3, "num": 3, "scale": "log"}}},
     ["body", "sweep", "device.delay", "start"]),
    ({"sweep": {"device.delay": {"start": 0, "stop": 1e-3, "num": 1000},
                "device.mass": {"start": 1, "stop": 2, "num": 1001}}}, ["body", "sweep"]),
    ({"sweep": {"device.delay": {"start": 0, "stop": 1e-3}}}, ["body", "sweep", "device.delay", "num"]),
    ({"sweep": {"device.mass": [1.0, -2.0]}}, ["body", "sweep", "device.mass"]),
    ({"sweep": {"device.delay": [0.0, 20.0]}}, ["body", "sweep", "device.delay"]),  # > MAX_DELAY_SAMPLES
    ({"sweep": {"requirements.min_gain_margin_db": [6.0]}}, ["body", "sweep", "requirements.min_gain_margin_db"]),
    ({"sweep": {}}, ["body", "sweep"]),
    ({"sampling": {"design": "latin_hypercube", "seed": 1}}, ["body", "sampling", "samples"]),
    ({"sampling": {"design": "latin_hypercube", "samples": 2_000_000, "seed": 1}}, ["body", "sampling", "samples"]),
    ({"base": {"device": {"mass": -1}}}, ["body", "base", "device"]),
])
def test_bad_sweeps_answer_422_naming_the_field(client, change, loc):
    req = {**small_study(), **change}
    r = client.post("/v1/studies", json=req)
    assert r.status_code == 422, r.text
    locs = [e["loc"] for e in r.json()["detail"]]
    assert any(l[:len(loc)] == loc for l in locs), locs


@pytest.mark.parametrize("token", ["NaN", "Infinity", "-Infinity", "1e400"])
def test_non_finite_sweep_values_answer_422(client, token):
    text = json.dumps(small_study()).replace('"requirements.damping": [0.0, 5.0]',
                                             f'"requirements.damping": [0.0, {token}]')
    r = client.post("/v1/studies", content=text, headers={"content-type": "application/json"})
    assert r.status_code == 422, r.text
    assert any(e["loc"][:3] == ["body", "sweep", "requirements.damping"] for e in r.json()["detail"])


def test_problem_missing_from_the_build_answers_422(client, monkeypatch):
    monkeypatch.setitem(sys.modules, "optim.transparency.inertia", None)  # import now raises ImportError
    monkeypatch.setattr(optim_studies, "_CACHE", {})
    r = client.post("/v1/studies", json={**small_study(), "problem": "inertia",
                                         "sweep": {"device.delay": [0.0]}, "base": {"device": LHIFAM_RIGID}})
    assert r.status_code == 422
    (err,) = r.json()["detail"]
    assert err["loc"] == ["body", "problem"] and "not available in this build" in err["msg"]


def test_latin_hypercube_is_stratified_and_reproducible(client):
    req = {"problem": "stability", "base": {"device": LHIFAM_RIGID},
           "sweep": {"device.delay": {"start": 1e-4, "stop": 1e-2, "scale": "log"},
                     "device.damping": {"start": 1.0, "stop": 9.0}},
           "sampling": {"design": "latin_hypercube", "samples": 10, "seed": 7}}
    ids = [client.post("/v1/studies", json=req).json()["id"] for _ in range(2)]
    rows = [ _all_json(client, i, 100) for i in ids if wait_finished(_get(client), i)["status"] == "done"]
    assert len(rows) == 2
    pairs = [[(r["device.delay"], r["device.damping"]) for r in rs] for rs in rows]
    assert pairs[0] == pairs[1]
    # one sample in each tenth of each axis (log-scaled for the delay)
    assert sorted(int(10 * math.log(d / 1e-4) / math.log(100)) for d, _ in pairs[0]) == list(range(10))
    assert sorted(int(10 * (b - 1.0) / 8.0) for _, b in pairs[0]) == list(range(10))


def test_cancel_and_purge(client):
    r = client.post("/v1/studies", json=small_study(num_delay=400))
    sid = r.json()["id"]
    st = client.delete(f"/v1/studies/{sid}").json()
    assert st["status"] == "cancelled"
    st = wait_finished(_get(client), sid)
    assert st["status"] == "cancelled" and st["done"] < st["total"]
    # the runner goes on with other work; purge removes the study and its rows
    for _ in range(50):
        r = client.delete(f"/v1/studies/{sid}", params={"purge": True})
        if r.status_code == 204:
            break
    assert r.status_code == 204
    assert client.get(f"/v1/studies/{sid}").status_code == 404


@pytest.mark.slow
def test_plots(client, finished):
    r = client.get(f"/v1/studies/{finished}/plot", params={"y": "critical_stiffness", "x": "device.delay"})
    assert r.status_code == 200 and r.content.startswith(b"\x89PNG")
    r = client.get(f"/v1/studies/{finished}/plot", params={"y": "gain_margin_db", "x": "device.delay",
                                                           "x2": "requirements.damping", "format": "svg"})
    assert r.status_code == 200 and b"<svg" in r.content[:500]
    r = client.get(f"/v1/studies/{finished}/plot", params={"y": "nonsense", "x": "device.delay"})
    assert r.status_code == 422 and r.json()["detail"][0]["loc"] == ["query", "y"]
    r = client.get(f"/v1/studies/{finished}/plot", params={"y": "critical_stiffness", "x": "device.mass"})
    assert r.status_code == 422 and r.json()["detail"][0]["loc"] == ["query", "x"]


def test_unknown_study_is_404(client):
    assert client.get("/v1/studies/nope").status_code == 404
    assert client.get("/v1/studies/nope/results").status_code == 404


@pytest.mark.slow
def test_stiffness_study_calls_the_design(client):
    """Each point is optim.stiffness.design_stiffness at that point; the margin holds on the exact K_cr."""
    stiffness = pytest.importorskip("optim.stiffness")
    req = {"problem": "stiffness", "base": {"device": LHIFAM_RIGID},
           "sweep": {"device.delay": [0.0, 0.002], "requirements.min_gain_margin_db": [6.0, 12.0]}}
    r = client.post("/v1/studies", json=req)
    assert r.status_code == 202, r.text
    sid = r.json()["id"]
    assert wait_finished(_get(client), sid, timeout=120)["status"] == "done"
    rows = _all_json(client, sid, 100)
    from models.device import Device
    from optim.stability.margins import critical_stiffness
    for row in rows:
        dev = Device(**LHIFAM_RIGID, delay=row["device.delay"])
        direct = stiffness.design_stiffness(dev, stiffness.StiffnessRequirements(
            min_gain_margin_db=row["requirements.min_gain_margin_db"]))
        assert row["status"] == direct.status == "optimal"
        assert (row["stiffness"], row["damping"]) == (direct.stiffness, direct.damping)
        # independent of the design: the exact K_cr at its B, and the margin it leaves
        kcr = critical_stiffness(dev, row["damping"]).critical_stiffness
        # the optimum sits on the margin: equality up to the design's own solver tolerance (1e-9 relative)
        assert row["stiffness"] <= kcr * 10 ** (-row["requirements.min_gain_margin_db"] / 20) * (1 + 1e-9)


@pytest.mark.slow
def test_critical_stiffness_study_end_to_end(client):
    """The vectorised problem through the API: each row is the exact per-point analysis to 1e-12 (its stated
    accuracy; vectorised arithmetic, so not bit for bit), and a point invalid only in combination fails alone."""
    from models.device import Device
    from optim.stability.analysis import analyse_stability

    req = {"problem": "critical_stiffness",
           "base": {"device": LHIFAM_RIGID, "requirements": {"stiffness": 1500.0}},
           "sweep": {"device.delay": [0.0, 0.0012, 0.02], "device.sample_time": [0.001, 1e-6],
                     "requirements.damping": [0.0, 5.0]}}
    r = client.post("/v1/studies", json=req)
    assert r.status_code == 202, r.text
    sid = r.json()["id"]
    st = wait_finished(_get(client), sid)
    assert (st["status"], st["done"], st["failed"]) == ("done", 12, 2), st  # 0.02 s / 1e-6 s > 10,000 samples
    page = client.get(f"/v1/studies/{sid}/results", params={"limit": 100}).json()
    assert {"critical_stiffness", "crossover_frequency", "max_stable_damping", "linear_estimate",
            "gain_margin_db", "stable", "reason"} <= set(page["columns"])
    for row in page["rows"]:
        if row["device.delay"] == 0.02 and row["device.sample_time"] == 1e-6:
            assert row["error"].startswith("invalid device") and row.get("critical_stiffness") is None
            continue
        assert row["error"] is None
        dev = Device(**{**LHIFAM_RIGID, "sample_time": row["device.sample_time"]}, delay=row["device.delay"])
        ref = analyse_stability(dev, 1500.0, row["requirements.damping"])
        assert row["critical_stiffness"] == pytest.approx(ref.critical_stiffness, rel=1e-12, abs=0.0)
        assert row["stable"] == ref.stable
        assert row["gain_margin_db"] == pytest.approx(ref.gain_margin_db, rel=0.0, abs=1e-10)  # 20/ln10 · 1e-12 dB
