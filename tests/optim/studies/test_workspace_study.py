"""The study problem workspace_critical_stiffness: poses swept as requirements, each point the workspace analysis's
own answer at that pose; bad requirements refused naming the field."""

from __future__ import annotations

import numpy as np
import pytest

from models.kinematics import KINEMATIC_PRESETS, load_kinematics
from optim.studies.problems import StudyInputError, evaluate_chunk, plan_study
from optim.workspace.workspace import workspace_map

DEVICE = {"mass": 1.0, "damping": 0.0, "sample_time": 0.001, "delay": 0.001}   # mass, damping unused: the arm's


def test_sweep_of_poses_matches_the_analysis():
    req = {"preset": "planar-2link", "joint_0": 0.3, "joint_1": 1.0, "normal_x": 0.0, "normal_y": 1.0,
           "normal_z": 0.0}
    plan = plan_study("workspace_critical_stiffness", DEVICE, req, {"requirements.joint_1": [0.5, 1.0, 2.0]})
    axes = [(a.path, a.kind) for a in plan.axes]
    rows = evaluate_chunk("workspace_critical_stiffness", DEVICE, req, axes, [(i, [v]) for i, v in
                                                                               enumerate([0.5, 1.0, 2.0])])
    arm = load_kinematics(**KINEMATIC_PRESETS["planar-2link"])
    for (_, values, result, error) in rows:
        assert error is None
        ref = workspace_map(arm, [np.array([0.3, values[0]])], [[0.0, 1.0, 0.0]], 0.001, 0.001).worst
        assert result["critical_stiffness"] == ref.critical_stiffness
        assert result["effective_mass"] == ref.effective_mass
        assert "gravity is taken as compensated" in result["note"]
    # at q = (0.3, 1.0), n = y: the worked example of docs/workspace.md (298.149 N/m)
    assert rows[1][2]["critical_stiffness"] == pytest.approx(298.149, rel=2e-6)


def test_worst_normal_and_a_singular_point():
    req = {"preset": "planar-2link", "joint_0": 0.0, "joint_1": 1.0}
    rows = evaluate_chunk("workspace_critical_stiffness", DEVICE, req, [("requirements.joint_1", "float")],
                          [(0, [1.0])])
    assert rows[0][3] is None and rows[0][2]["critical_stiffness"] > 0
    assert abs(np.hypot(rows[0][2]["normal.0"], rows[0][2]["normal.1"]) - 1.0) < 1e-12


@pytest.mark.parametrize("req, field", [
    ({"preset": "planar-2link", "joint_0": 0.0}, "joint_1"),
    ({"preset": "planar-2link", "joint_0": 0.0, "joint_1": 1.0, "joint_2": 0.0}, "joint_2"),
    ({"preset": "no-such", "joint_0": 0.0}, "preset"),
    ({"preset": "planar-2link", "joint_0": 0.0, "joint_1": 1.0, "normal_x": 1.0}, "normal"),
    ({"preset": "planar-2link", "joint_0": 0.0, "joint_1": 1.0, "damping": -1.0}, "damping"),
    ({"preset": "planar-2link", "joint_0": 0.0, "joint_1": 1.0, "colour": 1}, "colour"),
])
def test_bad_requirements_name_the_field(req, field):
    with pytest.raises(StudyInputError) as info:
        plan_study("workspace_critical_stiffness", DEVICE, req, {"requirements.joint_0": [0.0, 0.1]})
    assert field in info.value.field


def test_unresolvable_joint_damping_is_the_points_error_naming_the_field():
    """A joint damping whose mode decays at λ·T < 1e-9 (not 0): the point's error names joint_damping (it was a
    K_cr of ~1e-16 N/m, or a crash at 1e-300)."""
    req = {"preset": "planar-2link", "joint_0": 0.0, "joint_1": 1.0, "joint_damping": [1e-300, 1e-300]}
    rows = evaluate_chunk("workspace_critical_stiffness", DEVICE, req, [("requirements.joint_1", "float")],
                          [(0, [1.0])])
    assert rows[0][2] is None and "joint_damping" in str(rows[0][3])
