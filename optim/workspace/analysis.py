"""POST /v1/analysis/workspace's numerics from plain arguments (picklable: it runs in a compute worker)."""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from typing import Any, Literal, Sequence

from models.errors import InputError
from models.kinematics import KINEMATIC_PRESETS, KinematicModel, load_kinematics
from models.velocity_filter import (
    BackwardDifference,
    LowPass,
    MovingAverage,
    Rendering,
    TransferFunctionFilter,
    rendering,
)

from .workspace import (
    WorkspaceMap,
    WorkspacePoint,
    explicit_poses,
    grid_poses,
    lhs_poses,
    workspace_map,
    workspace_points,
)

__all__ = ["PoseSpec", "analyse_workspace", "analyse_workspace_part", "pose_count", "device_kinematics"]


@dataclass(frozen=True)
class PoseSpec:
    """Exactly one of: explicit poses [rad or m], ``grid_num`` values per joint, or ``lhs_samples`` with a seed."""

    explicit: tuple[tuple[float, ...], ...] | None = None
    grid_num: int | None = None
    lhs_samples: int | None = None
    lhs_seed: int = 0


def device_kinematics(urdf: str | None, preset: str | None, end_effector: str | None,
                      armature: Sequence[float] | None, joint_damping: Sequence[float] | None) -> KinematicModel:
    """The request's ``device.kinematics`` loaded (a preset's URDF and frame unless given); InputError fields are
    relative to the request body."""
    extra: dict[str, Any] = {}
    if preset is not None:
        if preset not in KINEMATIC_PRESETS:
            raise InputError("device.kinematics.preset", f"unknown kinematic preset {preset!r}; known: "
                                                         f"{', '.join(KINEMATIC_PRESETS)}")
        base = KINEMATIC_PRESETS[preset]
        if urdf is None:   # the preset's own URDF: with its coupling, joint names, limits and damping
            extra = {k: v for k, v in base.items() if k in ("coupling", "joint_names", "lower", "upper")}
            if joint_damping is None and "joint_damping" in base:
                joint_damping = base["joint_damping"]
        urdf = base["urdf"] if urdf is None else urdf
        end_effector = base["end_effector"] if end_effector is None else end_effector
    if urdf is None or end_effector is None:
        raise InputError("device.kinematics", "needs `urdf` and `end_effector`, or a `preset`")
    try:
        return load_kinematics(urdf, end_effector, None if armature is None else list(armature),
                               None if joint_damping is None else list(joint_damping), **extra)
    except InputError as exc:
        raise exc.under("device.kinematics.") from None


#: a controller's velocity filter (models.velocity_filter)
Filter = BackwardDifference | LowPass | MovingAverage | TransferFunctionFilter


def _poses(model: KinematicModel, poses: PoseSpec) -> list:
    if poses.explicit is not None:
        return explicit_poses(model, poses.explicit)
    if poses.grid_num is not None:
        return grid_poses(model, poses.grid_num)
    return lhs_poses(model, int(poses.lhs_samples or 0), poses.lhs_seed)


def analyse_workspace(urdf: str | None, preset: str | None, end_effector: str | None,
                      armature: Sequence[float] | None, joint_damping: Sequence[float] | None, poses: PoseSpec,
                      normals: Sequence[Sequence[float]] | Literal["worst"], sample_time: float, delay: float,
                      damping: float = 0.0, velocity_filter: Filter | None = None, virtual_mass: float = 0.0
                      ) -> tuple[WorkspaceMap, float]:
    """The workspace map and its elapsed time [ms]; InputError fields are relative to the request body.
    ``velocity_filter`` / ``virtual_mass`` [kg]: the rendered wall's (the controller's; None / 0: today's wall)."""
    start = time.perf_counter()
    rend = _rendering(velocity_filter, virtual_mass, sample_time)
    model = device_kinematics(urdf, preset, end_effector, armature, joint_damping)
    qs = _poses(model, poses)
    result = workspace_map(model, qs, normals if normals == "worst" else [list(n) for n in normals], sample_time,
                           delay, damping, explicit=poses.explicit is not None, rendering=rend)
    return replace(result), (time.perf_counter() - start) * 1e3


def analyse_workspace_part(urdf: str | None, preset: str | None, end_effector: str | None,
                           armature: Sequence[float] | None, joint_damping: Sequence[float] | None, poses: PoseSpec,
                           normals: Sequence[Sequence[float]] | Literal["worst"], sample_time: float, delay: float,
                           damping: float, velocity_filter: Filter | None, virtual_mass: float, part: int, parts: int
                           ) -> list[WorkspacePoint]:
    """The points of the ``part``-th of ``parts`` consecutive slices of the request's poses (every check on the
    whole request, as analyse_workspace): one compute worker's share; merge_points joins the shares in order."""
    rend = _rendering(velocity_filter, virtual_mass, sample_time)
    model = device_kinematics(urdf, preset, end_effector, armature, joint_damping)
    qs = _poses(model, poses)
    return workspace_points(model, qs, normals if normals == "worst" else [list(n) for n in normals], sample_time,
                            delay, damping, explicit=poses.explicit is not None, part=(part, parts),
                            rendering=rend)


def _rendering(velocity_filter: Filter | None, virtual_mass: float, sample_time: float) -> Rendering | None:
    """The controller's rendered wall at T (None: today's wall); InputError fields under ``controller.``."""
    if velocity_filter is None and virtual_mass == 0.0:
        return None
    try:
        return rendering(velocity_filter, virtual_mass, sample_time)
    except InputError as exc:
        raise exc.under("controller.") from None


def pose_count(poses: PoseSpec) -> int:
    """How many poses the request names, at least (a grid: num per joint, at least num)."""
    if poses.explicit is not None:
        return len(poses.explicit)
    if poses.grid_num is not None:
        return poses.grid_num
    return int(poses.lhs_samples or 0)
