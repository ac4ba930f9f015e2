"""POST /v1/design/stiffness: the stiffest safe wall, with its damping, limits and sensitivities."""

from __future__ import annotations

import math
import time

from fastapi import APIRouter
from fastapi.exceptions import RequestValidationError

from models.velocity_filter import LowPass
from optim.design_ladder import design_stiffness_on_rung, is_rendered
from optim.errors import InputError
from optim.robust.box import UncertaintyBox
from optim.robust.rendered_stiffness import robust_rendered_stiffness
from optim.robust.stiffness import robust_design_stiffness
from optim.solver_info import plain
from optim.stiffness import StiffnessRequirements
from optim.stiffness.rendered_filter import RenderedFilter
from optim.verification import claimed_epsilon, verify_stiffness_design
from optim.verification_robust import verify_robust_stiffness
from optim.workspace.analysis import PoseSpec
from optim.workspace.design import workspace_design_job
from service.cost import stiffness_design_cost_ms, verify_cost_ms
from service.errors import solver_trouble
from service.executor import Compute
from service.schemas.design_stiffness import StiffnessDesignRequest, StiffnessDesignResponse
from service.schemas.ladder import rung_fields
from service.schemas.verification import verification_out

router = APIRouter()




@router.post("/v1/design/stiffness", response_model=StiffnessDesignResponse, tags=["design"])
async def design_stiffness_route(request: StiffnessDesignRequest, compute: Compute) -> StiffnessDesignResponse:
    # The design runs in a compute worker under the request time budget, awaited without holding a thread
    # (service/cost.py), where the CasADi solvers are built and cached per process.
    t0 = time.perf_counter()
    req = request.requirements.core()
    ctrl = request.controller
    mass = ctrl.mass if ctrl is not None else 0.0
    vfilter = ctrl.velocity_filter if ctrl is not None else None
    rendered = is_rendered(req, mass, vfilter)
    if rendered and request.method != "exact":
        raise InputError("method", "designs of a rendered wall (a velocity filter, a designed cutoff or a virtual "
                                   "mass) are computed on the exact rung only")
    if request.requirements.workspace is not None:
        if not rendered:
            return await _workspace(request, req, t0, compute)
        spec = vfilter if vfilter is not None else req.velocity_filter
        if req.designs_cutoff:
            raise InputError("requirements.velocity_filter.design", "a workspace design takes a fixed velocity "
                             "filter: give its cutoff_hz (the cutoff is designed for one device only)")
        return await _workspace(request, req, t0, compute, (spec, mass))
    if request.requirements.uncertainty is not None:
        if request.method != "exact":
            raise InputError("method", "robust designs (requirements.uncertainty) are computed on the exact rung only")
        if rendered:
            spec = vfilter if vfilter is not None else req.velocity_filter
            return await _robust(request, req, t0, compute, (spec, mass))
        return await _robust(request, req, t0, compute)
    try:
        design, rung = await compute.arun(
            design_stiffness_on_rung, request.device, req, request.method, request.grid_points, mass, vfilter,
            cost_ms=None if rendered else stiffness_design_cost_ms(request.device, request.method, request.grid_points))
    except InputError:
        raise                   # 422 naming the field, as on every route (service.errors)
    except (RuntimeError, ArithmeticError, ValueError) as exc:   # CasADi raises RuntimeError on solver trouble
        return StiffnessDesignResponse(status="failed", reason=solver_trouble(exc),
                                       elapsed_ms=(time.perf_counter() - t0) * 1e3)
    data = plain(design)   # non-finite numbers answer null (FiniteModel)
    if request.verify and design.stiffness is not None and design.damping is not None:
        # the margin and (when required) the passivity the design claims, checked by the closed loop
        passive = True if req.passivity else None
        render = _render(design, req, vfilter)
        data["verification"] = verification_out(await compute.arun(
            verify_stiffness_design, request.device, design.stiffness, design.damping, design.gain_margin_db, passive,
            claimed_epsilon(rung.method, rung.error_estimate, linear_factor=2.0), None, render,
            cost_ms=verify_cost_ms(request.device)))
    return StiffnessDesignResponse(**data, **rung_fields(rung))


def _render(design, req: StiffnessRequirements, vfilter) -> tuple | None:
    """(velocity filter spec, virtual mass) of a rendered design for verify (None: today's wall)."""
    r = design.rendered
    if r is None:
        return None
    spec = vfilter if vfilter is not None else req.velocity_filter
    if r.designed:
        spec = LowPass(kind="low_pass", cutoff_hz=r.cutoff_hz, order=r.order)
    return (spec, r.mass)


def input_error(exc: ValueError) -> Exception:
    """An InputError as a 422 whose loc keeps an uncertainty path ("device.cable.stiffness") one element;
    any other exception is returned unchanged (re-raised by the caller)."""
    if not isinstance(exc, InputError):
        return exc
    prefix = "requirements.uncertainty."
    if exc.field.startswith(prefix):
        loc = ("body", "requirements", "uncertainty", exc.field[len(prefix):])
        return RequestValidationError([{"type": "value_error", "loc": loc, "msg": exc.rule, "input": None}])
    return exc


async def _robust(request: StiffnessDesignRequest, req: StiffnessRequirements, t0: float,
            compute: Compute, render: tuple | None = None) -> StiffnessDesignResponse:
    """The robust box; ``render``: a rendered wall's (fixed velocity filter spec, virtual mass M [kg])."""
    ranges = {k: (v.min, v.max) for k, v in request.requirements.uncertainty.items()}
    try:
        box = UncertaintyBox.from_ranges(request.device, ranges)
        if render is None:
            d = await compute.arun(robust_design_stiffness, request.device, req, box, cost_ms=None)  # always a worker
        else:
            d = await compute.arun(robust_rendered_stiffness, request.device, req, box, render[1], render[0],
                                   cost_ms=None)
    except InputError as exc:
        raise input_error(exc) from None
    except (RuntimeError, ArithmeticError, ValueError) as exc:   # numerical trouble, as the nominal design
        return StiffnessDesignResponse(status="failed", reason=solver_trouble(exc), robust=True,
                                       elapsed_ms=(time.perf_counter() - t0) * 1e3)
    data = plain(d)
    data.pop("nominal_critical_stiffness", None)
    worst = data.get("worst_case") or {}
    data["critical_stiffness"] = worst.get("critical_stiffness")
    data["crossover_frequency"] = worst.get("crossover_frequency")
    data["active_constraints"] = list(data["active_constraints"])
    if request.verify and d.status == "optimal":
        # every corner of the box and the worst (least passive) device found, on the closed loop
        data["verification"] = verification_out(await compute.arun(
            verify_robust_stiffness, box, d.stiffness, d.damping, req.min_gain_margin_db, req.passivity,
            worst.get("device"), (d.passivity_worst_case or {}).get("device"), render, cost_ms=None))
    return StiffnessDesignResponse(robust=True, **data)


#: requirements the workspace design does not take (each names its field in the 422)
_NOT_WITH_WORKSPACE = ("uncertainty", "passivity", "passive_with_quantization", "max_force", "max_penetration",
                       "quantization", "max_force_noise")


async def _workspace(request: StiffnessDesignRequest, req: StiffnessRequirements, t0: float,
                     compute: Compute, render: tuple | None = None) -> StiffnessDesignResponse:
    """requirements.workspace: one (K, B) over the poses and normals (optim.workspace.design); ``render``: a rendered
    wall's (fixed velocity filter spec, virtual mass M [kg])."""
    r = request.requirements
    for name in _NOT_WITH_WORKSPACE:
        if getattr(r, name) not in (None, False):
            raise InputError(f"requirements.{name}", "is not supported with requirements.workspace (the workspace "
                                                     "design takes min_gain_margin_db, max_damping, max_stiffness)")
    if request.method != "exact":
        raise InputError("method", "the workspace design is computed on the exact rung only")
    ws = r.workspace
    assert ws is not None
    if render is not None and ws.normals == "worst":     # refused before a worker starts (optim says the same)
        raise InputError("requirements.workspace.normals", "with a velocity filter or a virtual mass give the "
                         "normals: the search for the worst normal is available for today's wall only")
    kin, poses = ws.kinematics, ws.poses
    spec = PoseSpec(explicit=None if poses.explicit is None else tuple(tuple(q) for q in poses.explicit),
                    grid_num=None if poses.grid is None else poses.grid.num,
                    lhs_samples=None if poses.latin_hypercube is None else poses.latin_hypercube.samples,
                    lhs_seed=0 if poses.latin_hypercube is None else poses.latin_hypercube.seed)
    design, checks = await compute.arun(
        workspace_design_job, kin.urdf, kin.preset, kin.end_effector, kin.armature, kin.joint_damping, spec,
        ws.normals, request.device.sample_time, request.device.delay, req.min_gain_margin_db, req.max_damping,
        req.max_stiffness, ws.verify_factor, request.verify, *(render or ()), cost_ms=None)
    status = {"verified": "optimal", "unverified": "unsafe", "failed": "failed"}[design.status]
    binding = min(design.worst_cases, key=lambda c: c.critical_stiffness) if design.worst_cases else None
    kcr = binding.critical_stiffness if binding is not None else None
    margin = (20 * math.log10(kcr / design.stiffness) if kcr and design.stiffness else None)
    vw = design.verification_worst
    out = {"worst_cases": [plain(c) for c in design.worst_cases], "exchanges": design.exchanges,
           "design_poses": design.design_poses, "verification_poses": design.verification_poses,
           "verification_worst": None if vw is None else {"pose": vw.pose, "normal": vw.normal,
                                                          "critical_stiffness": vw.critical_stiffness},
           "verification_margin": design.verification_margin, "mimo_checks": [plain(c) for c in checks],
           "note": design.note}
    reason = design.reason
    if checks and not all(c.stable for c in checks) and status == "optimal":
        status, reason = "unsafe", "the full MIMO loop is unstable at the design at a worst case (mimo_checks)"
    extra = {}
    if render is not None:
        spec, mass = render
        extra["rendered"] = plain(RenderedFilter(getattr(spec, "kind", "backward_difference") if spec is not None
                                                 else "backward_difference", getattr(spec, "cutoff_hz", None),
                                                 getattr(spec, "order", None), False, mass=mass))
    return StiffnessDesignResponse(status=status, stiffness=design.stiffness, damping=design.damping,
                                   critical_stiffness=kcr, gain_margin_db=margin, reason=reason, robust=True,
                                   iterations=design.exchanges, workspace=out,
                                   elapsed_ms=(time.perf_counter() - t0) * 1e3, **extra)
