"""The study problem ``workspace_critical_stiffness``: K_cr of a multi-DOF device's wall at one pose per point.

A study sweeps poses as it sweeps any number: ``requirements.joint_0`` … ``requirements.joint_5`` are the pose's
joint values [rad or m], swept like any requirement; the device's ``sample_time`` and ``delay`` are the loop's (its
mass and damping are not used: the arm's own M(q), D and J(q) are).  Requirements:

* ``preset`` (a kinematic preset) or ``urdf`` with ``end_effector``; optional ``armature`` and ``joint_damping``;
* ``joint_0`` … : one value per joint (the device's joint count, each within its limits);
* ``normal_x``, ``normal_y``, ``normal_z``: the wall's normal in the base frame, or none of them for the pose's
  worst normal;
* ``damping``: the wall's virtual damping B [N·s/m] (default 0).

The answer is optim.workspace.workspace_map's point at that pose (the same numbers as POST /v1/analysis/workspace),
flattened.  A singular pose or one outside the limits is that point's failure, with the reason.
"""

from __future__ import annotations

import math
from typing import Any, Literal, Mapping, Sequence

from models.device import Device
from models.errors import InputError
from models.kinematics import KINEMATIC_PRESETS, KinematicModel

__all__ = ["REQUIREMENT_KINDS", "check_requirements", "evaluate_one"]

_MAX_JOINTS = 6
_JOINTS = tuple(f"joint_{i}" for i in range(_MAX_JOINTS))
_NORMAL = ("normal_x", "normal_y", "normal_z")
#: the sweepable requirements (numbers)
REQUIREMENT_KINDS: dict[str, str] = {**{j: "float" for j in _JOINTS}, **{n: "float" for n in _NORMAL},
                                     "damping": "float"}
_OTHER = ("preset", "urdf", "end_effector", "armature", "joint_damping")
_MODELS: dict[tuple, KinematicModel] = {}


def _number(req: Mapping[str, Any], key: str) -> float | None:
    v = req.get(key)
    if v is None:
        return None
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise InputError(key, f"must be a finite number, got {str(v)[:40]!r}")
    return float(v)


def _model(req: Mapping[str, Any]) -> KinematicModel:
    from optim.workspace.analysis import device_kinematics

    arm, damp = req.get("armature"), req.get("joint_damping")
    key = (req.get("preset"), req.get("urdf"), req.get("end_effector"),
           None if arm is None else tuple(arm), None if damp is None else tuple(damp))
    if key not in _MODELS:
        if len(_MODELS) > 8:
            _MODELS.clear()
        try:
            _MODELS[key] = device_kinematics(req.get("urdf"), req.get("preset"), req.get("end_effector"), arm, damp)
        except InputError as exc:
            raise InputError(exc.field.removeprefix("device.kinematics."), exc.rule) from None
    return _MODELS[key]


def check_requirements(req: Mapping[str, Any]) -> None:
    """InputError naming the requirement when the point cannot be evaluated."""
    unknown = sorted(set(req) - set(REQUIREMENT_KINDS) - set(_OTHER))
    if unknown:
        raise InputError(unknown[0], "unknown requirement of the workspace_critical_stiffness problem (known: "
                                     f"{', '.join(sorted([*REQUIREMENT_KINDS, *_OTHER]))})")
    preset = req.get("preset")
    if preset is not None and preset not in KINEMATIC_PRESETS:
        raise InputError("preset", f"unknown kinematic preset {str(preset)[:40]!r}; known: "
                                   f"{', '.join(KINEMATIC_PRESETS)}")
    for key in REQUIREMENT_KINDS:
        _number(req, key)
    b = _number(req, "damping")
    if b is not None and b < 0:
        raise InputError("damping", "must be ≥ 0")
    given = [n for n in _NORMAL if req.get(n) is not None]
    if given and len(given) != 3:
        raise InputError(_NORMAL[0] if _NORMAL[0] not in given else given[-1],
                         "give normal_x, normal_y and normal_z together, or none (the pose's worst normal)")
    model = _model(req)
    for i, j in enumerate(_JOINTS):
        if (i < model.dof) != (req.get(j) is not None):
            raise InputError(j, f"the device has {model.dof} joints ({', '.join(model.joint_names)}): give "
                                f"joint_0 … joint_{model.dof - 1}, no more")


def evaluate_one(device: Device, req: Mapping[str, Any]) -> dict[str, Any]:
    """K_cr at the point's pose (its worst normal, or the given one), flattened."""
    import numpy as np

    from optim.workspace.workspace import GRAVITY_NOTE, explicit_poses, workspace_map

    check_requirements(req)
    model = _model(req)
    q = np.array([float(req[j]) for j in _JOINTS[:model.dof]])
    normal: list[Sequence[float]] | Literal["worst"] = "worst"
    if req.get("normal_x") is not None:
        normal = [[float(req[n]) for n in _NORMAL]]
    try:
        pose = explicit_poses(model, [q.tolist()])
        res = workspace_map(model, pose, normal, device.sample_time, device.delay,
                            float(req.get("damping") or 0.0), explicit=True)
    except InputError as exc:   # the request's field names (poses.explicit.0, normals.0) as the study's
        field = ("pose" if exc.field.startswith("poses") else "normal" if exc.field.startswith("normals") else
                 exc.field.removeprefix("device.kinematics."))     # joint_damping: a mode's λ·T below 1e-9
        raise InputError(field, exc.rule) from None
    p = res.worst
    return {"critical_stiffness": p.critical_stiffness if math.isfinite(p.critical_stiffness) else None,
            "critical_frequency": p.critical_frequency, "normal.0": p.normal[0], "normal.1": p.normal[1],
            "normal.2": p.normal[2], "effective_mass": p.effective_mass, "effective_damping": p.effective_damping,
            "one_dof_critical_stiffness": p.one_dof_critical_stiffness
            if math.isfinite(p.one_dof_critical_stiffness) else None,
            "one_dof_relative_error": p.one_dof_relative_error, "modes": p.modes, "reason": p.reason,
            "note": GRAVITY_NOTE}
