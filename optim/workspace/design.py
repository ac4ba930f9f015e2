"""One wall (K, B) stable at every pose and normal of a multi-DOF device's workspace: the exchange method.

The design maximises K = g·min over (pose, normal) of K_cr(pose, normal; B) over B, g = 10^(−GM/20) the gain
margin asked for.  The minimum runs over an active set of worst cases only:

1. with the active set S, B* = argmax over B ∈ [0, B_cap] of min over S of K_cr(B) (a grid of B, then a bounded
   Brent polish; B_cap the smallest B_max of S, where K_cr falls to 0);
2. the workspace map at B* over every design pose (each pose's worst normal, or the given normals): if some
   (pose, normal) has K_cr below min over S (beyond 1e-9), it joins S and step 1 runs again;
3. otherwise K = g·min over S at B*, which every design (pose, normal) meets: its K_cr at B* is at least that.

Then the verification: the map at (K, B*) over a denser set of poses (a Latin hypercube of ``verify_factor`` ×
the design poses, different seed, plus the design poses) and its worst margin K_cr/K − 1.  ``verified`` only if
that margin is ≥ 0; otherwise the answer says where the design is not stable.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal, Sequence

import numpy as np

from models.errors import InputError
from models.kinematics import KinematicModel
from models.velocity_filter import Rendering, filter_spec, rendering

from .wall_plant import WallModes, max_stable_damping, wall_critical_stiffness, wall_modes
from .wall_rendered import RenderedWall
from .workspace import GRAVITY_NOTE, WorkspacePoint, lhs_poses, workspace_map

if TYPE_CHECKING:
    from .analysis import PoseSpec

__all__ = ["WorkspaceCase", "WorkspaceDesign", "design_workspace_stiffness", "MimoCheck", "mimo_checks",
           "workspace_design_job"]

_MAX_EXCHANGES = 25
_B_GRID = 24
_RTOL = 1e-9


@dataclass(frozen=True)
class WorkspaceCase:
    """A worst case of the exchange: pose [rad or m], unit normal, its K_cr at the design's B [N/m]."""

    pose: tuple[float, ...]
    normal: tuple[float, float, float]
    critical_stiffness: float


@dataclass(frozen=True)
class WorkspaceDesign:
    """K [N/m] and B [N·s/m] stable at every design pose and normal; the exchange's worst cases; the denser set's
    verification (its worst point at B and margin K_cr/K − 1)."""

    status: Literal["verified", "unverified", "failed"]
    stiffness: float | None
    damping: float | None
    gain: float
    worst_cases: tuple[WorkspaceCase, ...]
    exchanges: int
    design_poses: int
    verification_poses: int
    verification_worst: WorkspacePoint | None
    verification_margin: float | None
    reason: str | None = None
    note: str = GRAVITY_NOTE


def _modes(model: KinematicModel, pose: Sequence[float], normal: Sequence[float]) -> WallModes:
    mass, jac = model.at(np.asarray(pose, dtype=float))
    return wall_modes(mass, jac, model.joint_damping, np.asarray(normal, dtype=float))


def _best_b(cases: list[WallModes], t: float, td: float, b_cap: float,
            walls: list[RenderedWall] | None = None) -> tuple[float, float]:
    """(B*, min over the cases of K_cr at B*); ``walls``: the cases' rendered walls (None: today's wall)."""
    def worst(b: float) -> float:   # an unbounded K_cr (no crossover) as a huge finite number: the search stays real
        if walls is not None:
            return min(min(w.critical(b).critical_stiffness, 1e30) for w in walls)
        return min(min(wall_critical_stiffness(m, t, td, b).critical_stiffness, 1e30) for m in cases)

    grid = np.linspace(0.0, b_cap, _B_GRID + 1)[:-1]     # B_cap itself: K_cr = 0
    vals = [worst(float(b)) for b in grid]
    i = int(np.argmax(vals))
    lo = float(grid[max(i - 1, 0)])
    hi = float(grid[i + 1]) if i + 1 < len(grid) else b_cap
    # golden section on the bracket around the best grid point (the minimum of several K_cr(B) has kinks, where a
    # parabolic step misleads): to 1e-9 of B_cap
    g = (math.sqrt(5.0) - 1.0) / 2.0
    a, b = lo, hi
    x1, x2 = b - g * (b - a), a + g * (b - a)
    f1, f2 = worst(x1), worst(x2)
    while b - a > 1e-9 * max(b_cap, 1e-12):
        if f1 >= f2:
            b, x2, f2 = x2, x1, f1
            x1 = b - g * (b - a)
            f1 = worst(x1)
        else:
            a, x1, f1 = x1, x2, f2
            x2 = a + g * (b - a)
            f2 = worst(x2)
    x, fx = (x1, f1) if f1 >= f2 else (x2, f2)
    if fx > vals[i]:
        return float(x), float(fx)
    return float(grid[i]), float(vals[i])


def design_workspace_stiffness(model: KinematicModel, poses: list[np.ndarray],
                               normals: list[Sequence[float]] | Literal["worst"], sample_time: float, delay: float,
                               *, min_gain_margin_db: float = 0.0, max_damping: float | None = None,
                               verify_factor: int = 4, verify_seed: int = 1,
                               rendering: Rendering | None = None) -> WorkspaceDesign:
    """The exchange design over ``poses`` × ``normals`` and its verification on a denser set (module doc).
    ``rendering``: the rendered wall's velocity filter and virtual mass (optim.workspace.wall_rendered: the
    per-(pose, normal) plant with the filter; the normals must be given)."""
    if min_gain_margin_db < 0 or not math.isfinite(min_gain_margin_db):
        raise InputError("requirements.min_gain_margin_db", "must be finite and ≥ 0")
    gain = 10.0 ** (-min_gain_margin_db / 20.0)
    first = workspace_map(model, poses, normals, sample_time, delay, 0.0, rendering=rendering)
    start = min(first.points, key=lambda p: p.critical_stiffness)
    active = [(start.pose, start.normal)]
    cases = [_modes(model, *active[0])]
    walls = None if rendering is None else [RenderedWall(cases[0], sample_time, delay, rendering)]
    exchanges = 0
    b_star = k_min = 0.0
    for exchanges in range(1, _MAX_EXCHANGES + 1):
        if walls is not None:
            b_cap = min(w.max_stable_damping() for w in walls)
            if math.isnan(b_cap):
                return WorkspaceDesign("failed", None, None, gain, (), exchanges, len(poses), 0, None, None,
                                       reason="B_max of a worst case with this filter and virtual mass is not "
                                              "resolved (a crossing whose direction is not resolved)")
        else:
            b_cap = min(max_stable_damping(m, sample_time, delay) for m in cases)
        if max_damping is not None:
            b_cap = min(b_cap, max_damping * (1 + 1e-12))
        if not math.isfinite(b_cap):
            b_cap = max_damping if max_damping is not None else 1e3
        b_star, k_min = _best_b(cases, sample_time, delay, b_cap, walls)
        if not (k_min > 0 and math.isfinite(k_min)):
            return WorkspaceDesign("failed", None, None, gain, (), exchanges, len(poses), 0, None, None,
                                   reason="no (K, B) with K > 0 is stable at the worst cases found")
        now = workspace_map(model, poses, normals, sample_time, delay, b_star, rendering=rendering)
        worst = min(now.points, key=lambda p: p.critical_stiffness)
        if worst.critical_stiffness >= k_min * (1 - _RTOL):
            break
        active.append((worst.pose, worst.normal))
        cases.append(_modes(model, worst.pose, worst.normal))
        if walls is not None and rendering is not None:
            walls.append(RenderedWall(cases[-1], sample_time, delay, rendering))
    else:
        return WorkspaceDesign("failed", None, None, gain, (), exchanges, len(poses), 0, None, None,
                               reason=f"the exchange did not settle in {_MAX_EXCHANGES} rounds")
    stiffness = gain * k_min
    kcrs = ([w.critical(b_star).critical_stiffness for w in walls] if walls is not None else
            [wall_critical_stiffness(m, sample_time, delay, b_star).critical_stiffness for m in cases])
    worst_cases = tuple(WorkspaceCase(tuple(p), tuple(n), k)  # type: ignore[arg-type]
                        for (p, n), k in zip(active, kcrs))
    dense = lhs_poses(model, verify_factor * len(poses), verify_seed) + list(poses)
    check = workspace_map(model, dense, normals, sample_time, delay, b_star, rendering=rendering)
    vworst = min(check.points, key=lambda p: p.critical_stiffness)
    margin = vworst.critical_stiffness / stiffness - 1.0
    status: Literal["verified", "unverified"] = "verified" if margin >= 0 else "unverified"
    reason = None if margin >= 0 else (
        f"at pose {tuple(round(x, 6) for x in vworst.pose)} of the denser set, K_cr = {vworst.critical_stiffness:.6g}"
        f" N/m is below the design's K = {stiffness:.6g} N/m: design on more poses")
    return WorkspaceDesign(status, stiffness, b_star, gain, worst_cases, exchanges, len(poses), len(check.points),
                           vworst, margin, reason)


@dataclass(frozen=True)
class MimoCheck:
    """The full MIMO sampled loop (optim.workspace.mimo_loop) at the design's (K, B) at one pose and normal."""

    pose: tuple[float, ...]
    normal: tuple[float, float, float]
    spectral_radius: float
    stable: bool


def mimo_checks(model: KinematicModel, design: WorkspaceDesign, sample_time: float, delay: float,
                rendering: Rendering | None = None) -> tuple[MimoCheck, ...]:
    """The closed MIMO loop at every worst case of the exchange and at the denser set's worst point (``rendering``:
    with the velocity filter's and the virtual mass's states, V(z) on the normal penetration)."""
    from .mimo_loop import rendered_wall_spectral_radius, wall_spectral_radius

    if design.stiffness is None or design.damping is None:
        return ()
    points = [(c.pose, c.normal) for c in design.worst_cases]
    if design.verification_worst is not None:
        points.append((design.verification_worst.pose, design.verification_worst.normal))
    out = []
    for pose, normal in points:
        mass, jac = model.at(np.asarray(pose, dtype=float))
        if rendering is not None:
            rho = rendered_wall_spectral_radius(mass, jac, model.joint_damping, np.asarray(normal, dtype=float),
                                                design.stiffness, design.damping, sample_time, delay,
                                                filter_spec(rendering, sample_time), rendering.mass)
        else:
            rho = wall_spectral_radius(mass, jac, model.joint_damping, np.asarray(normal, dtype=float),
                                       design.stiffness, design.damping, sample_time, delay)
        out.append(MimoCheck(tuple(pose), tuple(normal), rho, rho < 1.0))  # type: ignore[arg-type]
    return tuple(out)


def workspace_design_job(urdf: str | None, preset: str | None, end_effector: str | None,
                         armature: Sequence[float] | None, joint_damping: Sequence[float] | None, poses: "PoseSpec",
                         normals: Sequence[Sequence[float]] | Literal["worst"], sample_time: float, delay: float,
                         min_gain_margin_db: float, max_damping: float | None, max_stiffness: float | None,
                         verify_factor: int, verify: bool, velocity_filter=None, virtual_mass: float = 0.0
                         ) -> tuple[WorkspaceDesign, tuple[MimoCheck, ...]]:
    """POST /v1/design/stiffness with requirements.workspace, from plain arguments (it runs in a compute worker);
    InputError fields are relative to the request body.  ``velocity_filter`` / ``virtual_mass`` [kg]: a rendered
    wall (fixed filter); None / 0: today's wall."""
    from .analysis import device_kinematics
    from .workspace import explicit_poses, grid_poses

    def under(exc: InputError) -> InputError:
        return InputError("requirements.workspace." + exc.field.removeprefix("device."), exc.rule)

    rend = None
    if velocity_filter is not None or virtual_mass != 0.0:
        try:
            rend = rendering(velocity_filter, virtual_mass, sample_time)
        except InputError as exc:
            raise exc.under("controller.") from None
    try:
        model = device_kinematics(urdf, preset, end_effector, armature, joint_damping)
        if poses.explicit is not None:
            qs = explicit_poses(model, poses.explicit)
        elif poses.grid_num is not None:
            qs = grid_poses(model, poses.grid_num)
        else:
            qs = lhs_poses(model, int(poses.lhs_samples or 0), poses.lhs_seed)
        given: list[Sequence[float]] | Literal["worst"] = "worst"
        if normals != "worst":
            given = [list(n) for n in normals]
        design = design_workspace_stiffness(model, qs, given, sample_time, delay,
                                            min_gain_margin_db=min_gain_margin_db, max_damping=max_damping,
                                            verify_factor=verify_factor, verify_seed=poses.lhs_seed + 1,
                                            rendering=rend)
    except InputError as exc:
        if exc.field.startswith(("requirements.", "controller.")):
            raise
        raise under(exc) from None
    if max_stiffness is not None and design.stiffness is not None and design.stiffness > max_stiffness:
        design = dataclasses.replace(design, stiffness=max_stiffness,
                                     verification_margin=None if design.verification_worst is None else
                                     design.verification_worst.critical_stiffness / max_stiffness - 1.0)
        if design.verification_margin is not None and design.verification_margin >= 0:
            design = dataclasses.replace(design, status="verified", reason=None)
    return design, (mimo_checks(model, design, sample_time, delay, rend) if verify else ())
