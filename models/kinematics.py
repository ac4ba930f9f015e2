"""A multi-DOF device's rigid-body model from its URDF (Pinocchio): joint-space inertia M(q), joint damping D and the
end effector's translational Jacobian J(q) in the base frame.

Gravity is taken as compensated and the velocity-product (Coriolis/centrifugal) terms as negligible at the wall
(small motion about the pose), so the plant at pose q is the linear M(q)·q̈ + D·q̇ = J(q)ᵀ·f.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

from models.errors import InputError

__all__ = ["KinematicModel", "load_kinematics", "MAX_URDF_CHARS", "KINEMATIC_PRESETS"]

#: The longest URDF text accepted [characters]: a desktop device's URDF is a few kB.
MAX_URDF_CHARS = 200_000

# A DOCTYPE (and with it any entity declaration, external or recursive) is refused before the text reaches the
# parser: Pinocchio's URDF reader never sees an entity to fetch or expand.  One linear scan, no backtracking.
_DTD = re.compile(r"<!\s*(DOCTYPE|ENTITY)", re.IGNORECASE)


def _planar_two_link() -> str:
    """A planar 2-link arm for teaching: links of 0.30 m and 0.25 m, point-like masses 1.0 kg and 0.6 kg at the
    links' middles with slender-rod inertias, joint damping 0.05 and 0.03 N·m·s/rad; the end effector at the
    second link's tip."""
    def link(name: str, mass: float, length: float) -> str:
        izz = mass * length ** 2 / 12.0
        return (f'<link name="{name}"><inertial><origin xyz="{length / 2} 0 0"/><mass value="{mass}"/>'
                f'<inertia ixx="1e-6" iyy="{izz}" izz="{izz}" ixy="0" ixz="0" iyz="0"/></inertial></link>')
    return ('<?xml version="1.0"?><robot name="planar_2link"><link name="base"/>'
            + link("upper", 1.0, 0.30) + link("fore", 0.6, 0.25) + '<link name="tip"/>'
            '<joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/><axis xyz="0 0 1"/>'
            '<limit lower="-3.1" upper="3.1" effort="10" velocity="10"/><dynamics damping="0.05"/></joint>'
            '<joint name="elbow" type="revolute"><parent link="upper"/><child link="fore"/>'
            '<origin xyz="0.30 0 0"/><axis xyz="0 0 1"/>'
            '<limit lower="0.1" upper="3.0" effort="10" velocity="10"/><dynamics damping="0.03"/></joint>'
            '<joint name="tool" type="fixed"><parent link="fore"/><child link="tip"/><origin xyz="0.25 0 0"/>'
            '</joint></robot>')


#: Built-in kinematic devices: URDF text and end-effector frame (their parameters are in the URDF).
KINEMATIC_PRESETS: dict[str, dict[str, str]] = {
    "planar-2link": {"urdf": _planar_two_link(), "end_effector": "tip"},
}


@dataclass(frozen=True)
class KinematicModel:
    """A parsed device: its Pinocchio model and the numbers the wall's plant needs.

    ``armature`` [kg·m² or kg] is added to M's diagonal; ``joint_damping`` [N·m·s/rad or N·s/m] is D's diagonal.
    ``lower``/``upper`` are the joint limits [rad or m] (finite: a pose grid needs them).
    """

    model: object = field(repr=False)
    frame_id: int
    joint_names: tuple[str, ...]
    armature: np.ndarray = field(repr=False)
    joint_damping: np.ndarray = field(repr=False)
    lower: np.ndarray = field(repr=False)
    upper: np.ndarray = field(repr=False)

    @property
    def dof(self) -> int:
        return len(self.joint_names)

    def at(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(M(q) with the armature [kg·m²], J(q) [m/rad]: the end effector's linear velocity in base axes)."""
        import pinocchio as pin

        model = self.model
        data = model.createData()  # type: ignore[attr-defined]
        q = np.asarray(q, dtype=float)
        n = self.dof
        mass = np.array(pin.crba(model, data, q), dtype=float).reshape(n, n)
        mass = np.triu(mass) + np.triu(mass, 1).T + np.diag(self.armature)
        jac = pin.computeFrameJacobian(model, data, q, self.frame_id, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        return mass, np.array(jac, dtype=float).reshape(6, n)[:3, :]


def _vector(values: list[float] | None, n: int, name: str, default: np.ndarray) -> np.ndarray:
    if values is None:
        return default
    if len(values) != n:
        raise InputError(name, f"needs one value per joint ({n}), got {len(values)}")
    out = np.asarray(values, dtype=float)
    if not np.all(np.isfinite(out)) or np.any(out < 0):
        raise InputError(name, "every value must be finite and ≥ 0")
    return out


def load_kinematics(urdf: str, end_effector: str, armature: list[float] | None = None,
                    joint_damping: list[float] | None = None) -> KinematicModel:
    """Parse ``urdf`` (Pinocchio) and check what the wall's plant needs; InputError names the field."""
    import pinocchio as pin

    if len(urdf) > MAX_URDF_CHARS:
        raise InputError("urdf", f"at most {MAX_URDF_CHARS} characters")
    if _DTD.search(urdf):
        raise InputError("urdf", "a DOCTYPE or ENTITY declaration is not accepted (no entities are expanded "
                                 "or fetched)")
    try:
        model = pin.buildModelFromXML(urdf)
    except (ValueError, RuntimeError) as exc:
        raise InputError("urdf", "is not a URDF that parses (" + str(exc).splitlines()[0][:120] + ")") from None
    if model.nv == 0:
        raise InputError("urdf", "has no moving joint")
    if model.nq != model.nv:
        raise InputError("urdf", "every joint must be revolute or prismatic (continuous, floating and planar "
                                 "joints have nq ≠ nv)")
    if not model.existFrame(end_effector):
        raise InputError("end_effector", f"no frame named {end_effector[:80]!r} in the URDF")
    names = tuple(model.names[i] for i in range(1, model.njoints))
    lower = np.array(model.lowerPositionLimit, dtype=float)
    upper = np.array(model.upperPositionLimit, dtype=float)
    arm = _vector(armature, model.nv, "armature", np.zeros(model.nv))
    damp = _vector(joint_damping, model.nv, "joint_damping", np.array(model.damping, dtype=float))
    model.armature = np.zeros(model.nv)   # the armature is added explicitly in KinematicModel.at
    data = model.createData()
    q0 = np.clip(np.zeros(model.nv), np.where(np.isfinite(lower), lower, -math.inf),
                 np.where(np.isfinite(upper), upper, math.inf))
    mass = np.array(pin.crba(model, data, q0), dtype=float).reshape(model.nv, model.nv)
    mass = np.triu(mass) + np.triu(mass, 1).T + np.diag(arm)
    eig = np.linalg.eigvalsh(mass)
    if not (np.all(np.isfinite(eig)) and eig[0] > 1e-12 * max(eig[-1], 1e-300) and eig[-1] > 0):
        raise InputError("urdf", "the joint-space inertia is singular (a joint moves no mass: zero inertia; add "
                                 "link inertias or an armature)")
    return KinematicModel(model, int(model.getFrameId(end_effector)), names, arm, damp, lower, upper)
