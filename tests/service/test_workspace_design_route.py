"""POST /v1/design/stiffness with requirements.workspace: the design through HTTP (its numbers are the numerics',
its label the MIMO loop's) and the 422s naming the field."""

from __future__ import annotations

import pytest

from models.kinematics import KINEMATIC_PRESETS, load_kinematics
from optim.workspace.design import design_workspace_stiffness
from optim.workspace.workspace import lhs_poses

DEVICE = {"mass": 1.0, "damping": 0.0, "sample_time": 0.001, "delay": 0.001}
WS = {"kinematics": {"preset": "planar-2link"}, "poses": {"latin_hypercube": {"samples": 3, "seed": 3}},
      "verify_factor": 1}


@pytest.mark.parametrize("extra, field", [
    ({"passivity": True}, "passivity"),
    ({"max_force": 5.0, "max_penetration": 0.01}, "max_force"),
    ({"uncertainty": {"device.mass": {"min": 0.5, "max": 1.5}}}, "uncertainty"),
])
def test_unsupported_requirements_are_refused(client, extra, field):
    r = client.post("/v1/design/stiffness", json={"device": DEVICE, "requirements": {"workspace": WS, **extra}})
    assert r.status_code == 422, r.text
    assert field in str(r.json()["detail"][0]["loc"])


def test_bad_workspace_names_the_field(client):
    bad = {**WS, "kinematics": {"preset": "planar-2link", "end_effector": "nowhere"}}
    r = client.post("/v1/design/stiffness", json={"device": DEVICE, "requirements": {"workspace": bad}})
    assert r.status_code == 422, r.text
    assert "end_effector" in str(r.json()["detail"][0]["loc"])


def test_unresolvable_joint_damping_names_the_field(client):
    """Joint damping 1e-300 (λ·T < 1e-9, not 0): a 422 on the workspace's joint_damping (it was a 500)."""
    bad = {**WS, "kinematics": {"preset": "phantom-premium-1.5", "joint_damping": [1e-300, 1e-300, 1e-300]},
           "poses": {"explicit": [[0.1, 0.2, 0.3]]}, "normals": "worst"}
    r = client.post("/v1/design/stiffness", json={"device": DEVICE, "requirements": {"workspace": bad}})
    assert r.status_code == 422, r.text
    assert r.json()["detail"][0]["loc"] == ["body", "requirements", "workspace", "kinematics", "joint_damping"]


@pytest.mark.slow
def test_workspace_design_through_http(client):
    r = client.post("/v1/design/stiffness", json={"device": DEVICE, "verify": True,
                                                  "requirements": {"min_gain_margin_db": 1.0, "workspace": WS}})
    assert r.status_code == 200, r.text
    body = r.json()
    arm = load_kinematics(**KINEMATIC_PRESETS["planar-2link"])
    ref = design_workspace_stiffness(arm, lhs_poses(arm, 3, 3), "worst", 0.001, 0.001, min_gain_margin_db=1.0,
                                     verify_factor=1, verify_seed=4)
    assert body["stiffness"] == pytest.approx(ref.stiffness, rel=1e-9)
    assert body["damping"] == pytest.approx(ref.damping, rel=1e-9)
    ws = body["workspace"]
    assert body["status"] == ("optimal" if ws["verification_margin"] >= 0 else "unsafe")
    assert ws["mimo_checks"] and all(c["stable"] == (c["spectral_radius"] < 1) for c in ws["mimo_checks"])
    assert "gravity" in ws["note"]
