"""Random arms for the workspace tests: the planar 2-link preset with random armature and damping, and random
3-DOF spatial arms (base yaw, shoulder and elbow pitch: the PHANToM's kinematic shape) written as URDF."""

from __future__ import annotations

import numpy as np

from models.kinematics import KINEMATIC_PRESETS, KinematicModel, load_kinematics


def _link(name: str, mass: float, length: float, axis: str) -> str:
    i_rod = mass * length ** 2 / 12.0
    com = {"x": f"{length / 2} 0 0", "z": f"0 0 {length / 2}"}[axis]
    small = 1e-5 * mass
    inertia = (f'ixx="{i_rod if axis == "z" else small}" iyy="{i_rod}" izz="{i_rod if axis == "x" else small}"')
    return (f'<link name="{name}"><inertial><origin xyz="{com}"/><mass value="{mass}"/>'
            f'<inertia {inertia} ixy="0" ixz="0" iyz="0"/></inertial></link>')


def spatial_arm_urdf(rng: np.random.Generator) -> str:
    h, l1, l2 = rng.uniform(0.05, 0.2), rng.uniform(0.1, 0.4), rng.uniform(0.1, 0.4)
    m0, m1, m2 = rng.uniform(0.05, 1.0, 3)
    b = rng.uniform(1e-4, 0.2, 3)
    return ('<?xml version="1.0"?><robot name="arm3"><link name="base"/>'
            + _link("turret", m0, h, "z") + _link("upper", m1, l1, "x") + _link("fore", m2, l2, "x")
            + '<link name="tip"/>'
            f'<joint name="yaw" type="revolute"><parent link="base"/><child link="turret"/><axis xyz="0 0 1"/>'
            f'<limit lower="-1.2" upper="1.2" effort="5" velocity="5"/><dynamics damping="{b[0]}"/></joint>'
            f'<joint name="shoulder" type="revolute"><parent link="turret"/><child link="upper"/>'
            f'<origin xyz="0 0 {h}"/><axis xyz="0 1 0"/>'
            f'<limit lower="-1.0" upper="1.0" effort="5" velocity="5"/><dynamics damping="{b[1]}"/></joint>'
            f'<joint name="elbow" type="revolute"><parent link="upper"/><child link="fore"/>'
            f'<origin xyz="{l1} 0 0"/><axis xyz="0 1 0"/>'
            f'<limit lower="0.3" upper="2.5" effort="5" velocity="5"/><dynamics damping="{b[2]}"/></joint>'
            f'<joint name="tool" type="fixed"><parent link="fore"/><child link="tip"/><origin xyz="{l2} 0 0"/>'
            '</joint></robot>')


def random_arm(rng: np.random.Generator) -> KinematicModel:
    if rng.random() < 0.5:
        pre = KINEMATIC_PRESETS["planar-2link"]
        return load_kinematics(pre["urdf"], pre["end_effector"], armature=list(rng.uniform(0, 0.02, 2)),
                               joint_damping=list(rng.uniform(1e-4, 0.3, 2)))
    return load_kinematics(spatial_arm_urdf(rng), "tip", armature=list(rng.uniform(0, 0.01, 3)))


def random_normal(rng: np.random.Generator, jac: np.ndarray) -> np.ndarray:
    """A unit normal: mostly in the range of J (the planar arm's plane), sometimes with a component outside it."""
    n = rng.normal(size=3)
    if np.linalg.matrix_rank(jac, tol=1e-9) < 3 and rng.random() < 0.7:
        u, _, _ = np.linalg.svd(jac)
        n = u[:, :2] @ rng.normal(size=2)
    return n / np.linalg.norm(n)
