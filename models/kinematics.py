"""A multi-DOF device's rigid-body model from its URDF (Pinocchio): joint-space inertia M(q), joint damping D and the
end effector's translational Jacobian J(q) in the base frame.

Gravity is taken as compensated and the velocity-product (Coriolis/centrifugal) terms as negligible at the wall
(small motion about the pose), so the plant at pose q is the linear M(q)·q̈ + D·q̇ = J(q)ᵀ·f.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any

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


# The PHANToM Premium 1.5's rigid-body parameters as Cavusoglu, Feygin & Tendick tabulate them ("A critical study of
# the mechanical and electrical properties of the PHANToM haptic interface and improvements for high-performance
# control", Presence 11(6), 2002, after Cavusoglu & Feygin, "Kinematics and dynamics of PHANToM model 1.5 haptic
# interface", UC Berkeley ERL memo M01/15, 2001); transcribed from the public implementation of that model in
# github.com/mahilab/Phantom (Model.cpp, step_dynamics_cavusoglu).  Masses [kg], inertias [kg·m²], lengths [m].
PHANTOM_15 = {
    "m_a": 0.0202, "I_axx": 0.4864e-4, "I_ayy": 0.001843e-4, "I_azz": 0.4864e-4,      # lower arm (COM at l2/2)
    "m_c": 0.0249, "I_cxx": 0.959e-4, "I_cyy": 0.959e-4, "I_czz": 0.0051e-4,          # parallelogram link
    "m_be": 0.2359, "I_bexx": 11.09e-4, "I_beyy": 10.06e-4, "I_bezz": 0.591e-4,      # upper arm + motor drum
    "m_df": 0.1906, "I_dfxx": 7.11e-4, "I_dfyy": 0.629e-4, "I_dfzz": 6.246e-4,       # crank + drum
    "I_baseyy": 11.87e-4,                                                           # the turret about its axis
    "l1": 0.215, "l2": 0.170, "l3": 0.0325,
}
#: Assumed, not in the paper: the viscous damping at each motor axis [N·m·s/rad] (the value the mahilab model uses).
PHANTOM_15_DAMPING = (5e-4, 5e-4, 5e-4)
#: Assumed, not in the paper: a box of (q1, q2, q3) [rad] inside the reachable workspace that avoids the singular
#: poses (the arm straight or folded, q3 − q2 = ±π/2, and the tip on the turret's axis).
PHANTOM_15_LIMITS = ((-0.9, -0.35, -0.35), (0.9, 0.9, 1.0))


def _phantom_premium_15() -> str:
    """The PHANToM Premium 1.5 (3 DOF) as a serial URDF whose kinetic energy is the paper's, in its base frame (y up,
    z towards the user, the tip at the origin at q = 0; x = sin q1 (l1 cos q2 + l2 sin q3), y = l2 − l2 cos q3 +
    l1 sin q2, z = −l1 + cos q1 (l1 cos q2 + l2 sin q3)).

    The parallelogram is a closed chain and q3 is the lower arm's absolute angle.  Here the URDF's elbow is the
    relative angle q3 − q2 (KINEMATIC_PRESETS' ``coupling`` maps the motor angles onto it), and each body enters
    by its kinetic energy: the upper arm (be, about its pivot) and the parallelogram link's rotation (c) on the upper
    link; the lower arm (a, about its COM at l2/2) and the crank's rotation (df, about its pivot: it turns with q3,
    as the lower arm does) on the lower link; the parallelogram link's translation, mc/2·|(l1/2)·v̇ + l3·ẇ|², is
    exactly that of a point mass mc/4 on the lower arm 2·l3 past the elbow.  Masses at a fixed pivot carry no
    kinetic energy (gravity is compensated), so be's and df's masses are placed there.  M(q) equals the paper's
    closed form (tests/models/test_kinematics.py)."""
    p = PHANTOM_15
    l1, l2, l3 = p["l1"], p["l2"], p["l3"]

    def inertial(mass: float, xyz: str, ixx: float, iyy: float, izz: float) -> str:
        return (f'<inertial><origin xyz="{xyz}"/><mass value="{mass!r}"/><inertia ixx="{ixx!r}" iyy="{iyy!r}" '
                f'izz="{izz!r}" ixy="0" ixz="0" iyz="0"/></inertial>')

    def joint(name: str, parent: str, child: str, xyz: str, lower: float, upper: float, axis: str = "-1 0 0"
              ) -> str:
        return (f'<joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
                f'<origin xyz="{xyz}"/><axis xyz="{axis}"/><limit lower="{lower!r}" upper="{upper!r}" effort="5" '
                'velocity="20"/></joint>')

    upper_i = [p["I_bexx"] + p["I_cxx"], p["I_beyy"] + p["I_cyy"], p["I_bezz"] + p["I_czz"]]
    lower_i = [p["I_axx"] + p["I_dfxx"], p["I_ayy"] + p["I_dfyy"], p["I_azz"] + p["I_dfzz"]]
    return ('<?xml version="1.0"?><robot name="phantom_premium_1_5"><link name="base"/>'
            '<link name="turret">' + inertial(0.0, "0 0 0", p["I_baseyy"], p["I_baseyy"], p["I_baseyy"])
            + '</link><link name="upper_arm">' + inertial(p["m_be"], "0 0 0", *upper_i)
            + '</link><link name="lower_arm">' + inertial(p["m_a"], f"0 {-l2 / 2!r} 0", *lower_i)
            + '</link><link name="parallelogram_translation">' + inertial(p["m_c"] / 4, "0 0 0", 0.0, 0.0, 0.0)
            + '</link><link name="stylus_tip"/>'
            + joint("q1", "base", "turret", f"0 {l2!r} {-l1!r}", -3.0, 3.0, axis="0 1 0")
            + joint("q2", "turret", "upper_arm", "0 0 0", -3.0, 3.0)
            + joint("elbow", "upper_arm", "lower_arm", f"0 0 {l1!r}", -3.0, 3.0)
            + f'<joint name="c_equivalent" type="fixed"><parent link="lower_arm"/><child '
              f'link="parallelogram_translation"/><origin xyz="0 {-2 * l3!r} 0"/></joint>'
            + f'<joint name="tip" type="fixed"><parent link="lower_arm"/><child link="stylus_tip"/>'
              f'<origin xyz="0 {-l2!r} 0"/></joint></robot>')


#: Built-in kinematic devices: load_kinematics' keyword arguments (URDF text, end-effector frame and, where the
#: URDF's joints are not the device's, the coupling and the device's own limits and damping).
KINEMATIC_PRESETS: dict[str, dict[str, Any]] = {
    "planar-2link": {"urdf": _planar_two_link(), "end_effector": "tip"},
    "phantom-premium-1.5": {"urdf": _phantom_premium_15(), "end_effector": "stylus_tip",
                            "coupling": ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, -1.0, 1.0)),
                            "joint_names": ("q1", "q2", "q3"),
                            "joint_damping": list(PHANTOM_15_DAMPING),
                            "lower": list(PHANTOM_15_LIMITS[0]), "upper": list(PHANTOM_15_LIMITS[1])},
}


@dataclass(frozen=True)
class KinematicModel:
    """A parsed device: its Pinocchio model and the numbers the wall's plant needs.

    ``armature`` [kg·m² or kg] is added to M's diagonal; ``joint_damping`` [N·m·s/rad or N·s/m] is D's diagonal.
    ``lower``/``upper`` are the joint limits [rad or m] (finite: a pose grid needs them).  ``coupling`` A maps the
    device's joint values onto the URDF's (q_urdf = A·q, A invertible: a parallelogram's absolute angle onto a
    serial chain's relative one); M, J, the damping and the limits are then the device's own.
    """

    model: object = field(repr=False)
    frame_id: int
    joint_names: tuple[str, ...]
    armature: np.ndarray = field(repr=False)
    joint_damping: np.ndarray = field(repr=False)
    lower: np.ndarray = field(repr=False)
    upper: np.ndarray = field(repr=False)
    coupling: np.ndarray | None = field(default=None, repr=False)

    @property
    def dof(self) -> int:
        return len(self.joint_names)

    def at(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(M(q) with the armature [kg·m²], J(q) [m/rad]: the end effector's linear velocity in base axes)."""
        import pinocchio as pin

        model = self.model
        data = model.createData()  # type: ignore[attr-defined]
        q = np.asarray(q, dtype=float)
        a = self.coupling
        qu = q if a is None else a @ q
        n = self.dof
        mass = np.array(pin.crba(model, data, qu), dtype=float).reshape(n, n)
        mass = np.triu(mass) + np.triu(mass, 1).T
        jac = pin.computeFrameJacobian(model, data, qu, self.frame_id, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        jac = np.array(jac, dtype=float).reshape(6, n)[:3, :]
        if a is not None:
            mass, jac = a.T @ mass @ a, jac @ a
        return mass + np.diag(self.armature), jac


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
                    joint_damping: list[float] | None = None, *,
                    coupling: tuple[tuple[float, ...], ...] | None = None,
                    joint_names: tuple[str, ...] | None = None, lower: list[float] | None = None,
                    upper: list[float] | None = None) -> KinematicModel:
    """Parse ``urdf`` (Pinocchio) and check what the wall's plant needs; InputError names the field.

    ``coupling``, ``joint_names``, ``lower`` and ``upper`` are a preset's (the device's joints when they are not the
    URDF's: KinematicModel.coupling)."""
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
    names = joint_names or tuple(model.names[i] for i in range(1, model.njoints))
    lo = np.array(model.lowerPositionLimit if lower is None else lower, dtype=float)
    hi = np.array(model.upperPositionLimit if upper is None else upper, dtype=float)
    a = None if coupling is None else np.array(coupling, dtype=float).reshape(model.nv, model.nv)
    arm = _vector(armature, model.nv, "armature", np.zeros(model.nv))
    damp = _vector(joint_damping, model.nv, "joint_damping", np.array(model.damping, dtype=float))
    model.armature = np.zeros(model.nv)   # the armature is added explicitly in KinematicModel.at
    data = model.createData()
    q0 = np.clip(np.zeros(model.nv), np.where(np.isfinite(lo), lo, -math.inf),
                 np.where(np.isfinite(hi), hi, math.inf))
    mass = np.array(pin.crba(model, data, q0 if a is None else a @ q0), dtype=float).reshape(model.nv, model.nv)
    mass = np.triu(mass) + np.triu(mass, 1).T
    mass = (mass if a is None else a.T @ mass @ a) + np.diag(arm)
    eig = np.linalg.eigvalsh(mass)
    if not (np.all(np.isfinite(eig)) and eig[0] > 1e-12 * max(eig[-1], 1e-300) and eig[-1] > 0):
        raise InputError("urdf", "the joint-space inertia is singular (a joint moves no mass: zero inertia; add "
                                 "link inertias or an armature)")
    return KinematicModel(model, int(model.getFrameId(end_effector)), names, arm, damp, lo, hi, a)
