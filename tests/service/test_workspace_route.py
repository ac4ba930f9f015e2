"""POST /v1/analysis/workspace through HTTP: the contract's one-link arm, the planar preset against the numerics,
and 422s that name the field."""

from __future__ import annotations

import numpy as np
import pytest

from models.kinematics import KINEMATIC_PRESETS, load_kinematics
from optim.workspace.wall_plant import wall_critical_stiffness, wall_modes

ONE_LINK = ('<?xml version="1.0"?><robot name="onelink"><link name="base"/><link name="arm"><inertial>'
            '<origin xyz="0.1 0 0"/><mass value="0.5"/><inertia ixx="1e-6" iyy="1e-6" izz="0.001" ixy="0" ixz="0" '
            'iyz="0"/></inertial></link><link name="tool"/><joint name="j" type="revolute"><parent link="base"/>'
            '<child link="arm"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="5" velocity="5"/>'
            '<dynamics damping="0.01"/></joint><joint name="t" type="fixed"><parent link="arm"/><child link="tool"/>'
            '<origin xyz="0.2 0 0"/></joint></robot>')


def test_one_link_effective_mass_is_inertia_over_length_squared(client):
    r = client.post("/v1/analysis/workspace", json={
        "device": {"sample_time": 0.001, "kinematics": {"urdf": ONE_LINK, "end_effector": "tool"}},
        "poses": {"explicit": [[0.0]]}, "normals": [[0.0, 1.0, 0.0]]})
    assert r.status_code == 200, r.text
    p = r.json()["points"][0]
    want = (0.5 * 0.1 ** 2 + 0.001) / 0.2 ** 2           # I_joint / l²
    assert p["effective_mass"] == pytest.approx(want, rel=1e-12)
    assert p["effective_damping"] == pytest.approx(0.01 / 0.2 ** 2, rel=1e-12)
    # one mode: the full plant is the 1-DOF plant, and K_cr is the rigid device's (b T/m = δ)
    assert p["modes"] == 1 and p["one_dof_relative_error"] == pytest.approx(0.0, abs=1e-12)


def test_planar_preset_matches_the_numerics(client):
    q, n = [0.3, 1.0], [0.0, 1.0, 0.0]
    r = client.post("/v1/analysis/workspace", json={
        "device": {"sample_time": 0.001, "delay": 0.0015, "kinematics": {"preset": "planar-2link"}},
        "controller": {"stiffness": 100.0, "damping": 0.2}, "poses": {"explicit": [q]}, "normals": [n]})
    assert r.status_code == 200, r.text
    body = r.json()
    model = load_kinematics(**KINEMATIC_PRESETS["planar-2link"])
    mass, jac = model.at(np.array(q))
    want = wall_critical_stiffness(wall_modes(mass, jac, model.joint_damping, np.array(n)), 0.001, 0.0015, 0.2)
    assert body["minimum_critical_stiffness"] == want.critical_stiffness
    assert body["worst"]["pose"] == q and "gravity" in body["note"]


@pytest.mark.parametrize(("body", "field"), [
    ({"device": {"kinematics": {"urdf": "<robot", "end_effector": "x"}}, "poses": {"explicit": [[0.0]]},
      "normals": [[0, 1, 0]]}, ["body", "device", "kinematics", "urdf"]),
    ({"device": {"kinematics": {"urdf": ONE_LINK, "end_effector": "nope"}}, "poses": {"explicit": [[0.0]]},
      "normals": [[0, 1, 0]]}, ["body", "device", "kinematics", "end_effector"]),
    ({"device": {"kinematics": {"preset": "planar-2link"}}, "poses": {"explicit": [[0.3, 1.0], [0.2, 3.05]]},
      "normals": [[0, 1, 0]]}, ["body", "poses", "explicit", 1]),                          # outside the limits
    ({"device": {"kinematics": {"urdf": ONE_LINK.replace('<joint name="t"', '<joint name="t2" type="fixed">'
                                                         '<parent link="tool"/><child link="tip"/><origin '
                                                         'xyz="0 0 0"/></joint><link name="tip"/><joint name="t"'),
                                "end_effector": "tool"}},
      "poses": {"explicit": [[0.0]]}, "normals": [[0, 0, 1]]}, ["body", "normals", 0]),  # Jᵀn = 0
    ({"device": {"kinematics": {"preset": "planar-2link"}}, "poses": {"grid": {"num": 400}}, "normals": "worst"},
     ["body", "poses", "grid", "num"]),                                                    # > 10⁵ poses
    ({"device": {"kinematics": {"preset": "planar-2link"}}, "poses": {"explicit": [[0.3, 1.0]]},
      "normals": [[0, 0, 0]]}, ["body", "normals", 0]),
    ({"device": {"kinematics": {"urdf": '<?xml version="1.0"?><!DOCTYPE r [<!ENTITY x SYSTEM "file:///etc/passwd">'
                                        ']><robot name="&x;"/>', "end_effector": "x"}},
      "poses": {"explicit": [[0.0]]}, "normals": [[0, 1, 0]]}, ["body", "device", "kinematics", "urdf"]),
    ({"device": {"kinematics": {"preset": "phantom-premium-1.5", "joint_damping": [1e-300, 1e-300, 1e-300]}},
      "poses": {"explicit": [[0.1, 0.2, 0.3]]}, "normals": "worst"},
     ["body", "device", "kinematics", "joint_damping"]),         # λ·T < 1e-9: was a 500 (complex division by 0)
])
def test_bad_input_names_its_field(client, body, field):
    r = client.post("/v1/analysis/workspace", json=body)
    assert r.status_code == 422, r.text
    assert any(e["loc"][:len(field)] == field for e in r.json()["detail"]), r.text


def test_singular_explicit_pose_is_named(client):
    urdf = KINEMATIC_PRESETS["planar-2link"]["urdf"].replace('lower="0.1" upper="3.0"', 'lower="-3.0" upper="3.0"')
    r = client.post("/v1/analysis/workspace", json={
        "device": {"kinematics": {"urdf": urdf, "end_effector": "tip"}},
        "poses": {"explicit": [[0.3, 1.0], [0.3, 0.0]]}, "normals": [[0, 1, 0]]})
    assert r.status_code == 422 and r.json()["detail"][0]["loc"] == ["body", "poses", "explicit", 1]
    assert "singular" in r.json()["detail"][0]["msg"]


@pytest.mark.slow
def test_workspace_plot_renders(client, tmp_path):
    r = client.post("/v1/plots/workspace?format=png", json={
        "device": {"sample_time": 0.001, "delay": 0.001, "kinematics": {"preset": "planar-2link"}}, "points": 7})
    assert r.status_code == 200 and r.headers["content-type"] == "image/png" and r.content[:4] == b"\x89PNG"
    (tmp_path / "workspace.png").write_bytes(r.content)
    bad = client.post("/v1/plots/workspace", json={
        "device": {"kinematics": {"preset": "planar-2link"}}, "x_joint": 5})
    assert bad.status_code == 422 and bad.json()["detail"][0]["loc"][-1] == "x_joint"


def test_a_split_request_is_the_one_worker_answer(client):
    """80 poses go to the two compute workers in two slices: the same points, in order, and the same worst as one
    worker's map; a singular explicit pose in the second slice is named by its index in the whole list."""
    from optim.workspace.analysis import PoseSpec, analyse_workspace

    body = {"device": {"sample_time": 0.001, "delay": 0.0005, "kinematics": {"preset": "planar-2link"}},
            "poses": {"latin_hypercube": {"samples": 80, "seed": 4}}, "normals": [[0.0, 1.0, 0.0], [0.6, 0.8, 0.0]]}
    r = client.post("/v1/analysis/workspace", json=body)
    assert r.status_code == 200, r.text
    got = r.json()
    want, _ = analyse_workspace(None, "planar-2link", None, None, None, PoseSpec(lhs_samples=80, lhs_seed=4),
                                [[0.0, 1.0, 0.0], [0.6, 0.8, 0.0]], 0.001, 0.0005)
    assert [p["critical_stiffness"] for p in got["points"]] == [p.critical_stiffness for p in want.points]
    assert [p["pose"] for p in got["points"]] == [list(p.pose) for p in want.points]
    assert got["worst"]["pose"] == list(want.worst.pose) and got["worst"]["normal"] == list(want.worst.normal)
    urdf = KINEMATIC_PRESETS["planar-2link"]["urdf"].replace('lower="0.1" upper="3.0"', 'lower="-3.0" upper="3.0"')
    poses = [[0.3, 1.0]] * 70 + [[0.3, 0.0]]
    r = client.post("/v1/analysis/workspace", json={
        "device": {"kinematics": {"urdf": urdf, "end_effector": "tip"}}, "poses": {"explicit": poses},
        "normals": [[0, 1, 0]]})
    assert r.status_code == 422 and r.json()["detail"][0]["loc"] == ["body", "poses", "explicit", 70]


def test_an_undamped_joint_gives_zero_with_the_reason(client):
    """The PHANToM with joint damping (0, 0, 0.002) at B = 0: the worst normal's K_cr is 0 with the reason (the search
    used to answer ~1e-4 N/m), and the 1-DOF approximation's error is null there (no relative error of 0)."""
    r = client.post("/v1/analysis/workspace", json={
        "device": {"sample_time": 0.001, "delay": 0.0005,
                   "kinematics": {"preset": "phantom-premium-1.5", "joint_damping": [0.0, 0.0, 0.002]}},
        "poses": {"explicit": [[0.1, 0.2, 0.3]]}, "normals": "worst"})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["minimum_critical_stiffness"] == 0.0
    p = body["points"][0]
    assert p["critical_stiffness"] == 0.0 and p["one_dof_relative_error"] is None
    assert "undamped" in p["reason"]
