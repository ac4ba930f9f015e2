"""The workspace map: K_cr of the wall at every pose and normal of a multi-DOF device, and the worst of them.

At each pose the plant along a normal n is optim.workspace.wall_plant's exact G_n (every mode, exact ZOH and delay);
beside it the 1-DOF approximation (the effective mass and damping as one rigid plant) with its own exact K_cr.
``normals="worst"`` searches the unit sphere for the normal of lowest K_cr: only normals in the range of J(q) can
be worst (a component outside it scales every mode's weight by cos²φ and raises K_cr by 1/cos²φ), so the search
runs over that range — a point, a half circle or a half sphere (n and −n give the same loop) — by a dense sampling
and a bounded local polish of the best samples.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, Sequence

import numpy as np
from scipy.stats import qmc

from models.errors import InputError
from models.kinematics import KinematicModel
from models.velocity_filter import Rendering

from .normal_search import dual_normal, undamped_normal, worst_normal
from .wall_plant import (
    WallCritical,
    WallModes,
    check_mode_rates,
    one_dof_critical_stiffness,
    one_dof_equivalent,
    pose_eig,
    wall_critical_stiffness,
    wall_modes,
)
from .wall_rendered import RenderedWall

__all__ = ["WorkspacePoint", "WorkspaceMap", "workspace_map", "workspace_points", "merge_points", "explicit_poses", "grid_poses", "lhs_poses",
           "MAX_EVALUATIONS", "GRAVITY_NOTE"]

#: At most this many (pose, normal) pairs in one request (a study takes more).
MAX_EVALUATIONS = 100_000
#: The dual worst normal (B = 0, rank 3) is taken when the exact scan's K_cr there equals its prediction to this.
_DUAL_AGREE = 1e-9
#: A pose is singular when J's smallest singular value (of those the device has generically) is below this
#: fraction of the largest.
_SINGULAR = 1e-9

GRAVITY_NOTE = ("gravity is taken as compensated and the velocity-product (Coriolis/centrifugal) terms as negligible "
                "at the wall: the plant is the linearisation M(q)·q̈ + D·q̇ = J(q)ᵀ·f at each pose")


@dataclass(frozen=True)
class WorkspacePoint:
    """One pose and normal: K_cr of the full G_n [N/m], the effective mass [kg] and damping [N·s/m] along n, and the
    exact K_cr of that 1-DOF approximation [N/m] with its relative error against the full plant."""

    pose: tuple[float, ...]
    normal: tuple[float, float, float]
    critical_stiffness: float
    critical_frequency: float | None
    effective_mass: float
    effective_damping: float
    one_dof_critical_stiffness: float
    one_dof_relative_error: float | None
    modes: int
    reason: str | None = None


@dataclass(frozen=True)
class WorkspaceMap:
    """Every point, the worst one (lowest K_cr) and its K_cr [N/m]."""

    points: tuple[WorkspacePoint, ...]
    worst: WorkspacePoint
    minimum_critical_stiffness: float
    normals: Literal["given", "worst"]
    note: str = GRAVITY_NOTE


def _generic_rank(model: KinematicModel) -> int:
    rng = np.random.default_rng(0)
    lo = np.where(np.isfinite(model.lower), model.lower, -math.pi)
    hi = np.where(np.isfinite(model.upper), model.upper, math.pi)
    best = 0
    for _ in range(5):
        _, jac = model.at(rng.uniform(lo, hi))
        s = np.linalg.svd(jac, compute_uv=False)
        best = max(best, int(np.sum(s > 1e-9 * max(s[0], 1e-300))))
    return best


def _check_pose(model: KinematicModel, q: Sequence[float], where: str) -> np.ndarray:
    arr = np.asarray(q, dtype=float)
    if arr.shape != (model.dof,):
        raise InputError(where, f"a pose has one value per joint ({model.dof}: {', '.join(model.joint_names)}), "
                                f"got {len(q)}")
    if not np.all(np.isfinite(arr)):
        raise InputError(where, "every joint value must be finite")
    out = (arr < model.lower - 1e-12) | (arr > model.upper + 1e-12)
    if np.any(out):
        j = int(np.argmax(out))
        raise InputError(where, f"joint {model.joint_names[j]!r} = {arr[j]:g} is outside its limits "
                                f"[{model.lower[j]:g}, {model.upper[j]:g}]")
    return arr


def explicit_poses(model: KinematicModel, poses: Sequence[Sequence[float]]) -> list[np.ndarray]:
    return [_check_pose(model, q, f"poses.explicit.{i}") for i, q in enumerate(poses)]


def _finite_limits(model: KinematicModel, where: str) -> tuple[np.ndarray, np.ndarray]:
    if not (np.all(np.isfinite(model.lower)) and np.all(np.isfinite(model.upper))):
        raise InputError(where, "needs finite joint limits in the URDF (give explicit poses otherwise)")
    return model.lower, model.upper


def grid_poses(model: KinematicModel, num: int) -> list[np.ndarray]:
    """``num`` values per joint, evenly spaced over its limits (num^dof poses)."""
    lo, hi = _finite_limits(model, "poses.grid")
    if num ** model.dof > MAX_EVALUATIONS:
        raise InputError("poses.grid.num", f"num^{model.dof} poses exceed {MAX_EVALUATIONS}")
    axes = [np.linspace(a, b, num) for a, b in zip(lo, hi)]
    mesh = np.meshgrid(*axes, indexing="ij")
    return [np.array(p) for p in np.stack([m.ravel() for m in mesh], axis=1)]


def lhs_poses(model: KinematicModel, samples: int, seed: int) -> list[np.ndarray]:
    """A Latin hypercube of ``samples`` poses over the joint limits (scipy.stats.qmc, seeded)."""
    lo, hi = _finite_limits(model, "poses.latin_hypercube")
    unit = qmc.LatinHypercube(d=model.dof, seed=seed).random(samples)
    return [np.array(p) for p in qmc.scale(unit, lo, hi)]


def _point(q: np.ndarray, n: np.ndarray, modes: WallModes, sample_time: float, delay: float, damping: float,
           full: WallCritical | None = None, rendering: Rendering | None = None) -> WorkspacePoint:
    if rendering is not None:
        full = RenderedWall(modes, sample_time, delay, rendering).critical(damping)
        k1 = RenderedWall(one_dof_equivalent(modes), sample_time, delay, rendering).critical(damping).critical_stiffness
    else:
        if full is None:
            full = wall_critical_stiffness(modes, sample_time, delay, damping)
        k1 = one_dof_critical_stiffness(modes, sample_time, delay, damping)
    k = full.critical_stiffness
    err = (k1 / k - 1.0) if (math.isfinite(k) and k > 0 and math.isfinite(k1)) else None
    return WorkspacePoint(tuple(float(x) for x in q), (float(n[0]), float(n[1]), float(n[2])), k, full.frequency,
                          modes.effective_mass, modes.effective_damping, k1, err, len(modes.c), full.reason)


def workspace_map(model: KinematicModel, poses: list[np.ndarray], normals: list[Sequence[float]] | Literal["worst"],
                  sample_time: float, delay: float, damping: float = 0.0, *, explicit: bool = False,
                  rendering: Rendering | None = None) -> WorkspaceMap:
    """K_cr at every pose × normal (or each pose's worst normal) and the minimum over them.

    ``explicit`` poses are the user's own: a singular one is refused, naming it; sampled poses skip singular ones.
    ``rendering``: the rendered wall's velocity filter and virtual mass (optim.workspace.wall_rendered; the normals
    must then be given: the worst-normal search is today's wall's).
    """
    points = workspace_points(model, poses, normals, sample_time, delay, damping, explicit=explicit,
                              rendering=rendering)
    return merge_points([points], normals)


def merge_points(parts: Sequence[Sequence[WorkspacePoint]], normals: object) -> WorkspaceMap:
    """The map of the points of consecutive slices of the poses (workspace_points of each, in order): the worst is
    the first point of lowest K_cr, as over one list."""
    points = tuple(p for part in parts for p in part)
    if not points:
        raise InputError("poses", "every sampled pose is singular")
    worst = min(points, key=lambda p: p.critical_stiffness)
    return WorkspaceMap(points, worst, worst.critical_stiffness, "worst" if normals == "worst" else "given")


def _unseen_undamped(mass: np.ndarray, jac: np.ndarray, damping_q: np.ndarray, eig: tuple[np.ndarray, np.ndarray],
                     n: np.ndarray, sample_time: float, delay: float, damping: float) -> np.ndarray:
    """The search's normal, or its projection off the undamped modes' directions (w_i = J v_i, λ_i = 0) when that is
    no higher.  With B > 0 the worst normal often lies where the undamped modes are not seen (K_cr is continuous as
    their weight c₀ → 0): the polish ends a rounding-sized c₀ short of it (nᵀJe_z ~ 1e-9), where the undamped
    mode's pole sits 1e-17 inside z = 1 and the MIMO check reads its side from rounding; the projection sees them
    exactly not at all (mimo_loop.unmoved then leaves the pole out)."""
    lam, vec = eig
    zero = lam == 0.0
    if not zero.any():
        return n
    w = jac @ vec[:, zero]
    basis, sv, _ = np.linalg.svd(w, full_matrices=False)
    basis = basis[:, sv > 1e-12 * max(float(sv[0]) if sv.size else 0.0, 1e-300)]
    proj = n - basis @ (basis.T @ n)
    norm = float(np.linalg.norm(proj))
    if norm < 1e-6 or not np.any(np.abs(proj @ jac) > 0.0):
        return n
    proj = proj / norm
    k_n = wall_critical_stiffness(wall_modes(mass, jac, damping_q, n, eig), sample_time, delay, damping)
    k_p = wall_critical_stiffness(wall_modes(mass, jac, damping_q, proj, eig), sample_time, delay, damping)
    return proj if k_p.critical_stiffness <= k_n.critical_stiffness * (1.0 + 1e-9) else n


def workspace_points(model: KinematicModel, poses: list[np.ndarray],
                     normals: list[Sequence[float]] | Literal["worst"], sample_time: float, delay: float,
                     damping: float = 0.0, *, explicit: bool = False, part: tuple[int, int] = (0, 1),
                     rendering: Rendering | None = None) -> list[WorkspacePoint]:
    """The points of workspace_map (its checks on the whole request), of the ``part`` = (i, k)-th of k consecutive
    slices of ``poses`` only (a request split over compute workers; a singular explicit pose is named by its index
    in the whole list)."""
    if rendering is not None and normals == "worst":
        raise InputError("normals", "with a velocity filter or a virtual mass give the normals: the search for the "
                                    "worst normal is available for today's wall only")
    given: list[np.ndarray] = []
    if normals != "worst":
        for i, n in enumerate(normals):
            v = np.asarray(n, dtype=float)
            norm = float(np.linalg.norm(v)) if v.shape == (3,) and np.all(np.isfinite(v)) else 0.0
            if norm == 0.0:
                raise InputError(f"normals.{i}", "a normal is three finite numbers, not all zero")
            given.append(v / norm)
    count = len(poses) * (1 if normals == "worst" else len(given))
    if count > MAX_EVALUATIONS:
        raise InputError("poses", f"{count} pose × normal pairs exceed {MAX_EVALUATIONS} in one request "
                                  "(a study takes more)")
    if not poses:
        raise InputError("poses", "no pose to analyse")
    rank = _generic_rank(model)
    points: list[WorkspacePoint] = []
    i_part, parts = part
    first, last = i_part * len(poses) // parts, (i_part + 1) * len(poses) // parts
    for j in range(first, last):
        q = poses[j]
        mass, jac = model.at(q)
        s = np.linalg.svd(jac, compute_uv=False)
        if rank and s[rank - 1] <= _SINGULAR * max(s[0], 1e-300):
            if explicit:
                raise InputError(f"poses.explicit.{j}", "is a singular pose (the end effector cannot move in "
                                                        "every direction it generically can)")
            continue
        pose_normals: list[np.ndarray]
        eig = pose_eig(mass, model.joint_damping)
        check_mode_rates(eig[0], sample_time)
        if normals == "worst" and damping == 0.0 and rendering is None:
            n0 = undamped_normal(jac, eig, sample_time, delay)
            if n0 is not None:     # K_cr = 0 along n0 (a ≤ τ·c₀): the worst, decided exactly
                modes = wall_modes(mass, jac, model.joint_damping, n0, eig)
                points.append(_point(q, n0, modes, sample_time, delay, damping))
                continue
        if normals == "worst" and rank == 3 and damping == 0.0:
            dual = dual_normal(mass, jac, model.joint_damping, sample_time, delay, eig)
            if dual is not None:
                modes = wall_modes(mass, jac, model.joint_damping, dual[0], eig)
                full = wall_critical_stiffness(modes, sample_time, delay, damping)
                if abs(full.critical_stiffness / dual[1] - 1.0) <= _DUAL_AGREE:
                    points.append(_point(q, dual[0], modes, sample_time, delay, damping, full))
                    continue
        if normals == "worst":
            n_w = worst_normal(mass, jac, model.joint_damping, rank, sample_time, delay, damping)
            pose_normals = [_unseen_undamped(mass, jac, model.joint_damping, eig, n_w, sample_time, delay, damping)]
        else:
            pose_normals = given
        for i, n_vec in enumerate(pose_normals):
            modes = wall_modes(mass, jac, model.joint_damping, n_vec, eig)
            if not modes.c:
                raise InputError(f"normals.{i}", f"the device cannot move along this normal at pose {j} "
                                                 "(Jᵀn = 0): no wall can be rendered there")
            points.append(_point(q, n_vec, modes, sample_time, delay, damping, rendering=rendering))
    return points
