"""POST /v1/design/stiffness with requirements.workspace and a rendered wall (issue 30): through HTTP, the numbers are
optim.workspace.design's with the filter (tests/optim/workspace/test_wall_rendered.py holds them to the MIMO loop), the
label the MIMO loop's with the filter's states; the refusals name their field."""

from __future__ import annotations

import pytest

from models.kinematics import KINEMATIC_PRESETS, load_kinematics
from models.velocity_filter import LowPass, rendering
from optim.workspace.design import design_workspace_stiffness
from optim.workspace.workspace import lhs_poses
from tests.service.conftest import make_client

DEVICE = {"mass": 1.0, "damping": 0.0, "sample_time": 0.001, "delay": 0.001}
NORMALS = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
WS = {"kinematics": {"preset": "planar-2link"}, "poses": {"latin_hypercube": {"samples": 3, "seed": 3}},
      "verify_factor": 1, "normals": NORMALS}
LP50 = {"kind": "low_pass", "cutoff_hz": 50, "order": 1}


@pytest.fixture(scope="module")
def client():
    with make_client(request_timeout=300.0) as c:
        yield c


@pytest.mark.parametrize("body,loc", [
    ({"requirements": {"workspace": {**WS, "normals": "worst"}}, "controller": {"velocity_filter": LP50}},
     ["requirements", "workspace", "normals"]),
    ({"requirements": {"workspace": WS, "velocity_filter": {"kind": "low_pass", "design": True, "order": 1,
                                                            "min_cutoff_hz": 5, "max_cutoff_hz": 200}}},
     ["requirements", "velocity_filter", "design"]),
    ({"requirements": {"workspace": WS}, "controller": {"velocity_filter": LP50}, "method": "grid"}, ["method"]),
])
def test_refusals_name_the_field(client, body, loc):
    r = client.post("/v1/design/stiffness", json={"device": DEVICE, **body})
    assert r.status_code == 422, r.text[:300]
    got = [x for x in r.json()["detail"][0]["loc"] if x != "body"]
    assert ".".join(map(str, got)).endswith(".".join(loc)), got


@pytest.mark.slow      # a compute worker starts (~10-30 s); the design itself takes ~2 s
def test_workspace_design_with_a_filter_through_http(client):
    r = client.post("/v1/design/stiffness", json={"device": DEVICE, "controller": {"velocity_filter": LP50},
                                                  "requirements": {"min_gain_margin_db": 1.0, "workspace": WS},
                                                  "verify": True})
    assert r.status_code == 200, r.text[:300]
    body = r.json()
    arm = load_kinematics(**KINEMATIC_PRESETS["planar-2link"])
    ref = design_workspace_stiffness(arm, lhs_poses(arm, 3, 3), NORMALS, 0.001, 0.001, min_gain_margin_db=1.0,
                                     verify_factor=1, verify_seed=4,
                                     rendering=rendering(LowPass(**LP50), 0.0, 0.001))
    assert body["status"] == "optimal" and body["stiffness"] == pytest.approx(ref.stiffness, rel=1e-9)
    assert body["rendered"]["cutoff_hz"] == 50
    assert body["workspace"]["mimo_checks"] and all(c["stable"] for c in body["workspace"]["mimo_checks"])


def test_the_workspace_analysis_renders_the_controllers_filter(client):
    # POST /v1/analysis/workspace took a controller of K and B only: the map is now the rendered wall's (the same
    # numbers as optim.workspace.workspace_map with the filter), not today's wall's
    q, n = [0.3, 1.0], [0.0, 1.0, 0.0]
    base = {"device": {"sample_time": 0.001, "delay": 0.001, "kinematics": {"preset": "planar-2link"}},
            "poses": {"explicit": [q]}, "normals": [n]}
    plain = client.post("/v1/analysis/workspace", json={**base, "controller": {"stiffness": 100.0, "damping": 0.2}})
    r = client.post("/v1/analysis/workspace", json={**base, "controller": {"damping": 0.2, "velocity_filter": LP50}})
    assert plain.status_code == 200 and r.status_code == 200, r.text[:300]
    arm = load_kinematics(**KINEMATIC_PRESETS["planar-2link"])
    import numpy as np

    from optim.workspace.workspace import workspace_map
    want = workspace_map(arm, [np.array(q)], [n], 0.001, 0.001, 0.2, explicit=True,
                         rendering=rendering(LowPass(**LP50), 0.0, 0.001))
    got = r.json()["minimum_critical_stiffness"]
    assert got == pytest.approx(want.minimum_critical_stiffness, rel=1e-12)
    assert got != pytest.approx(plain.json()["minimum_critical_stiffness"], rel=1e-3)
    worst = client.post("/v1/analysis/workspace", json={**base, "normals": "worst",
                                                         "controller": {"velocity_filter": LP50}})
    assert worst.status_code == 422 and worst.json()["detail"][0]["loc"][-1] == "normals"
    bad = client.post("/v1/analysis/workspace", json={**base, "controller": {"velocity_filter": {
        "kind": "low_pass", "cutoff_hz": 600, "order": 1}}})
    assert bad.status_code == 422 and "velocity_filter" in ".".join(map(str, bad.json()["detail"][0]["loc"]))
