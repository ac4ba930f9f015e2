"""POST /v1/analysis/stability and /v1/analysis/boundary: thin calls into optim."""

from __future__ import annotations

from dataclasses import asdict, fields
from typing import Annotated

from fastapi import APIRouter, Body
from pydantic import ValidationError

from models.device import Device
from models.velocity_filter import Rendering, rendering
from optim.errors import InputError
from optim.nonlinear_verification import verify_nonlinear
from optim.stability.analysis import analyse_stability
from optim.stability.boundary import stability_boundary
from optim.stability.nonlinear import analyse_nonlinear
from optim.verification import verify_analysis, verify_boundary

from ..cost import (
    boundary_cost_ms,
    check_reference_cost,
    nonlinear_cost_ms,
    nonlinear_verify_cost_ms,
    rendered_cost_ms,
    stability_cost_ms,
    verify_cost_ms,
)
from ..errors import numerics_refused
from ..executor import Compute
from ..schemas.analysis import BoundaryRequest, BoundaryResponse, StabilityRequest, StabilityResponse
from ..schemas.common import device_examples
from ..schemas.verification import verification_out

router = APIRouter(prefix="/v1/analysis", tags=["analysis"])


def field_error(exc: ValueError, prefix: str = "") -> InputError:
    """The numerics' ValueError as a 422: an InputError names its field (located under ``prefix``, e.g.
    "device."); any other ValueError of an analysis is the device's numbers defeating the arithmetic.

    A pydantic ValidationError is a ValueError too, but one raised inside the numerics means an internal
    model was misused: a bug, re-raised so that it answers 500 without its text.
    """
    if isinstance(exc, InputError):
        return exc.under(prefix) if prefix else exc
    if isinstance(exc, ValidationError):
        raise exc
    return numerics_refused(exc, "device")


def _rendering(controller, device: Device) -> Rendering | None:
    """The controller's velocity filter and virtual mass at the device's T (None when it names neither: today's
    wall, its fast path); the filter's rules that need T (a cutoff below Nyquist, a stable velocity estimate) as
    422s under ``controller.``."""
    if controller is None or not controller.rendered:
        return None
    try:
        return rendering(controller.velocity_filter, controller.mass, device.sample_time)
    except InputError as exc:
        raise exc.under("controller.") from None


def _shallow(res) -> dict:
    """``asdict`` of a StabilityAnalysis without its recursive deep copy (~0.1 ms, a sixth of the request): its only
    nested dataclasses are the crossovers, plain pairs of floats."""
    out = {f.name: getattr(res, f.name) for f in fields(res)}
    out["crossovers"] = [{"frequency": c.frequency, "stiffness": c.stiffness} for c in res.crossovers]
    mass = out.pop("mass_range")
    if mass is not None:
        out["mass_range"] = {"min": mass.min, "max": mass.max}
    return out


def nonlinear_out(nl) -> dict:
    """optim.stability.nonlinear.NonlinearAnalysis as the response's ``nonlinear`` block."""
    p, c = nl.passive, nl.limit_cycle
    return {"passive_stiffness_limit": p.stiffness, "sampling_term": p.sampling_term,
            "quantization_term": p.quantization_term, "binding": p.binding, "source": p.source, "covered": p.covered,
            "limit_cycle": {"exists": c.exists, "amplitude": c.amplitude, "frequency_hz": c.frequency_hz,
                            "threshold_amplitude": c.threshold_amplitude, "method": c.method, "error": c.error},
            "regime": nl.regime, "reason": nl.reason}


def nonlinear_verification_out(v) -> dict:
    """optim.nonlinear_verification.NonlinearVerification as the block's ``verification``."""
    def audit(a) -> dict | None:
        return None if a is None else {"net_energy": a.net_energy, "port_balance_max": a.port_balance_max, "hold_energy": a.hold_energy,
                "error_bound": a.error_bound, "active": a.active, "mode": a.mode,
                "hold_motion_counts": a.hold_motion_counts, "push_force": a.push_force}
    return {"verdict": v.verdict, "reason": v.reason, "chatter_probe": audit(v.chatter_probe),
            "instability_probe": audit(v.instability_probe),
            "measured_state": v.measured.state if v.measured else None,
            "measured_amplitude": v.measured.amplitude if v.measured else None,
            "measured_frequency_hz": v.measured.frequency_hz if v.measured else None,
            "predicted_amplitude": v.predicted_amplitude, "predicted_frequency_hz": v.predicted_frequency_hz,
            "release_from": v.release_from}


_STABILITY_EXAMPLES = {
    **device_examples(),
    "margin-of-a-wall": {"summary": "gain margin and passivity of K = 3500 N/m, B = 5 N·s/m with 1 ms delay",
                         "value": {"device": {"preset": "lhifam", "delay": 0.001},
                                   "controller": {"stiffness": 3500, "damping": 5}}},
    "linear-rung": {"summary": "closed-form estimate (eq. 10)", "value": {"device": {"mass": 5.4, "damping": 3.5},
                                                                         "method": "linear"}},
}


@router.post("/stability", response_model=StabilityResponse, operation_id="analyse_stability",
             summary="Critical stiffness K_cr(B), every crossover, margin and passivity of a wall")
async def stability(req: Annotated[StabilityRequest, Body(openapi_examples=_STABILITY_EXAMPLES)],
              compute: Compute) -> StabilityResponse:
    k = req.controller.stiffness if req.controller else None
    b = req.controller.damping if req.controller else 0.0
    check_reference_cost(req.device, req.method)
    rendered = _rendering(req.controller, req.device)
    args = (rendered,) if rendered is not None else ()
    try:
        res = await compute.arun(analyse_stability, req.device, k, b, req.method, req.grid_points, *args,
                                 cost_ms=rendered_cost_ms(stability_cost_ms(req.device, req.method, b,
                                                                           req.grid_points), rendered))
    except ValueError as exc:
        raise field_error(exc) from exc
    out = _shallow(res)   # non-finite numbers answer null (FiniteModel)
    if req.device.nonlinear:
        try:
            nl = await compute.arun(analyse_nonlinear, req.device, k, b, rendered,
                                    cost_ms=rendered_cost_ms(nonlinear_cost_ms(req.device, b), rendered, calls=300))
        except ValueError as exc:
            raise field_error(exc) from exc
        out["nonlinear"] = nonlinear_out(nl)
        if req.verify and k is not None:
            try:
                wall = None if rendered is None else req.controller.model_dump(include={"velocity_filter", "mass"},
                                                                               exclude_unset=True)
                v = await compute.arun(verify_nonlinear, req.device, k, b, nl, None, wall,
                                       cost_ms=nonlinear_verify_cost_ms(req.device))
            except ValueError as exc:
                raise field_error(exc) from exc
            out["nonlinear"]["verification"] = nonlinear_verification_out(v)
    if rendered is not None:
        out.setdefault("mass_range", None)
    if req.verify:   # only when asked: the fast path does no extra work
        spec = (req.controller.velocity_filter, req.controller.mass) if rendered is not None else None
        out["verification"] = verification_out(await compute.arun(verify_analysis, req.device, res, spec,
                                                           cost_ms=verify_cost_ms(req.device)))
    return StabilityResponse(**out)


@router.post("/boundary", response_model=BoundaryResponse, operation_id="stability_boundary",
             summary="The stability boundary K_cr(B) from B = 0 to B_max and the B allowing the stiffest wall")
async def boundary(req: Annotated[BoundaryRequest, Body(openapi_examples=device_examples(points=20))],
             compute: Compute) -> BoundaryResponse:
    rendered = _rendering(req.controller, req.device)
    try:
        res = await compute.arun(stability_boundary, req.device, req.damping_max, req.points, rendered,
                                 cost_ms=rendered_cost_ms(boundary_cost_ms(req.device, req.points), rendered,
                                                          calls=req.points + 25))
    except ValueError as exc:
        raise field_error(exc) from exc
    verification = None
    if req.verify:
        spec = (req.controller.velocity_filter, req.controller.mass) if rendered is not None else None
        verification = verification_out(await compute.arun(verify_boundary, req.device, res, spec,
                                                    cost_ms=(req.points + 1) * verify_cost_ms(req.device)))
    return BoundaryResponse(points=[asdict(p) for p in res.points], optimum=asdict(res.optimum),
                            max_stable_damping=res.max_stable_damping, method="exact", elapsed_ms=res.elapsed_ms,
                            verification=verification)
