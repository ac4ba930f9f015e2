"""Studies sweep the rendered wall (issue 30): controller.velocity_filter.cutoff_hz and controller.mass, through the
HTTP contract; each row is the exact analysis (POST /v1/analysis/stability) of that point, and bad input is a 422
naming the field with nothing stored."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient

from service.app import create_app
from service.settings import Settings
from tests.service.studies_helpers import LHIFAM_RIGID, wait_finished

LOW_PASS = {"kind": "low_pass", "cutoff_hz": 50.0, "order": 1}


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    db = tmp_path_factory.mktemp("rendered_studies") / "store.db"
    mp = pytest.MonkeyPatch()
    mp.setenv("ZWIDTH_STUDY_WORKERS", "1")
    mp.setenv("ZWIDTH_STUDY_CHUNK_SIZE", "4")
    mp.setenv("ZWIDTH_PRESTART_WORKERS", "false")     # the 422 cases need no worker: none started up front
    with TestClient(create_app(Settings(database_url=f"sqlite:///{db}"))) as c:
        yield c
    mp.undo()


def _rows(client, sid: str) -> list[dict]:
    page = client.get(f"/v1/studies/{sid}/results", params={"offset": 0, "limit": 1000}).json()
    return page["rows"]


def _run(client, body: dict) -> list[dict]:
    r = client.post("/v1/studies", json=body)
    assert r.status_code == 202, r.text
    st = wait_finished(lambda sid: client.get(f"/v1/studies/{sid}").json(), r.json()["id"], timeout=120)
    assert st["status"] == "done", st
    return _rows(client, r.json()["id"])


@pytest.mark.slow
def test_cutoff_and_mass_sweep_rows_are_the_analysis(client):
    """≈ 20 s at load 16 (the worker process loads the compiled kernels; 6 full analyses)."""
    body = {"problem": "stability",
            "base": {"device": LHIFAM_RIGID, "requirements": {"stiffness": 5000.0, "damping": 50.0},
                     "controller": {"velocity_filter": LOW_PASS}},
            "sweep": {"controller.velocity_filter.cutoff_hz": [20.0, 200.0], "controller.mass": [-1.0, 0.0, 2.0]}}
    rows = _run(client, body)
    assert len(rows) == 6
    stable_masses = 0
    for row in rows:
        f, m = row["controller.velocity_filter.cutoff_hz"], row["controller.mass"]
        one = client.post("/v1/analysis/stability", json={
            "device": LHIFAM_RIGID, "controller": {"stiffness": 5000.0, "damping": 50.0, "mass": m,
                                                   "velocity_filter": {**LOW_PASS, "cutoff_hz": f}}}).json()
        assert row["error"] is None, row
        assert row["critical_stiffness"] == pytest.approx(one["critical_stiffness"], rel=1e-12)
        assert row["max_stable_damping"] == pytest.approx(one["max_stable_damping"], rel=1e-12)
        assert row["stable"] == one["stable"] and row["passive"] == one["passive"]
        if one.get("mass_range") is None:
            assert row["mass_range.min"] is None and row["mass_range.max"] is None and not one["stable"]
        else:
            assert row["mass_range.min"] == pytest.approx(one["mass_range"]["min"], rel=1e-12)
            assert row["mass_range.max"] == pytest.approx(one["mass_range"]["max"], rel=1e-12)
            stable_masses += 1
    assert stable_masses >= 3
    # the lag of a 20 Hz filter lowers K_cr below the 200 Hz one's at each mass
    by = {(r["controller.velocity_filter.cutoff_hz"], r["controller.mass"]): r["critical_stiffness"] for r in rows}
    assert all(by[(20.0, m)] < by[(200.0, m)] for m in (-1.0, 0.0, 2.0))


@pytest.mark.slow
def test_critical_stiffness_study_sweeps_the_mass_without_a_base_controller(client):
    """≈ 20 s at load 16 alone (the study worker's start and kernels), ≈ 0.3 s after the other study."""
    body = {"problem": "critical_stiffness", "base": {"device": LHIFAM_RIGID, "requirements": {"damping": 20.0}},
            "sweep": {"controller.mass": [0.0, 1.0]}}
    rows = _run(client, body)
    plain = client.post("/v1/analysis/stability", json={"device": LHIFAM_RIGID,
                                                        "controller": {"stiffness": 1000.0, "damping": 20.0}}).json()
    at0 = next(r for r in rows if r["controller.mass"] == 0.0)
    # M = 0 with the backward difference is today's wall
    assert at0["critical_stiffness"] == pytest.approx(plain["critical_stiffness"], rel=1e-12)


@pytest.mark.parametrize("body, field", [
    ({"base": {"controller": {"velocity_filter": {**LOW_PASS, "cutoff_hz": 600.0}}}}, "base.controller.velocity_filter.cutoff_hz"),
    ({"sweep": {"controller.velocity_filter.cutoff_hz": [50.0, 800.0]}}, "sweep.controller.velocity_filter.cutoff_hz"),
    ({"base": {"controller": {"velocity_filter": {"kind": "moving_average", "samples": 0}}}},
     "base.controller.velocity_filter.samples"),
    ({"base": {"controller": {"mass": "heavy"}}}, "base.controller.mass"),
    ({"base": {"controller": {"stiffness": 10.0}}}, "base.controller.stiffness"),
    ({"problem": "stiffness", "base": {"controller": {"mass": 1.0}}}, "base.controller"),
    ({"sweep": {"controller.velocity_filter.gain": [1.0]}}, "sweep.controller.velocity_filter.gain"),
])
def test_bad_controllers_answer_422_naming_the_field(client, body, field):
    before = client.get("/v1/studies").json()["studies"]
    req = {"problem": "stability",
           "base": {"device": LHIFAM_RIGID, "requirements": {"stiffness": 2000.0},
                    "controller": {"velocity_filter": LOW_PASS}},
           "sweep": {"controller.mass": [0.0, 1.0]}}
    req["problem"] = body.get("problem", req["problem"])
    req["base"] = {**req["base"], **body.get("base", {})}
    req["sweep"] = body.get("sweep", req["sweep"])
    r = client.post("/v1/studies", json=req)
    assert r.status_code == 422, r.text
    locs = [".".join(str(x) for x in e["loc"][1:]) for e in r.json()["detail"]]
    assert any(loc == field or loc.startswith(field + ".") for loc in locs), (field, r.text)
    assert client.get("/v1/studies").json()["studies"] == before
