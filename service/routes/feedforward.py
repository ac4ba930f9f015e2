"""POST /v1/analysis/force-feedforward and /v1/design/inertia: thin calls into optim (chapter §5)."""

from __future__ import annotations

import math
import time

from fastapi import APIRouter

from models.filters import ButterworthLowPass
from optim.design_ladder import design_inertia_on_rung
from optim.errors import InputError
from optim.transparency.feedforward import apparent_mass, resolve_human
from optim.transparency.inertia import RIGID_OPTIMISM_FLAG, InertiaRequirements
from optim.verification import claimed_epsilon, verify_critical_force_gain, verify_force_feedforward

from ..cost import force_feedforward_cost_ms, inertia_design_cost_ms, verify_cost_ms
from ..errors import numerics_refused
from ..executor import Compute
from ..jobs import force_feedforward_job
from ..schemas.feedforward import ForceFeedforwardRequest, ForceFeedforwardResponse, InertiaRequest, InertiaResponse
from ..schemas.ladder import rung_fields
from ..schemas.verification import verification_out

router = APIRouter(tags=["transparency"])


def _field_error(exc: ValueError, prefix: str = "") -> InputError:
    """An InputError located in the body (its field under ``prefix`` unless it already starts at device or
    requirements); any other ValueError of the analysis is about the device."""
    if not isinstance(exc, InputError):
        return numerics_refused(exc, "device")
    return exc if exc.field.startswith(("device", "requirements")) else exc.under(prefix)


def _human_notes(source: str) -> list[str]:
    if "eq. 30" in source:
        return ["the device has no human block: the chapter's eq. 30 grasp Z_h = 2 s² + 2 s + 10 was used"]
    return []


@router.post("/v1/analysis/force-feedforward", response_model=ForceFeedforwardResponse)
async def force_feedforward(req: ForceFeedforwardRequest, compute: Compute) -> ForceFeedforwardResponse:
    start = time.perf_counter()
    dev = req.device
    try:
        filt = ButterworthLowPass(req.filter.order, req.filter.cutoff_hz, dev.sample_time) if req.filter else None
        res, rigid = await compute.arun(force_feedforward_job, dev, filt, req.method, req.grid_points,
                                        cost_ms=force_feedforward_cost_ms(dev, req.method, req.grid_points))
    except ValueError as exc:
        raise _field_error(exc, "filter.") from exc
    kcr = res.critical_force_gain
    notes = _human_notes(res.human_source)
    optimistic = None
    if rigid is not None:
        optimistic = rigid > res.critical_force_gain * (1 + RIGID_OPTIMISM_FLAG)
        if optimistic:
            notes.append(f"the rigid model is optimistic: it claims K_f,cr = {rigid:.4g}, "
                         f"{100 * (rigid / res.critical_force_gain - 1):.0f} % above the cable model's {kcr:.4g}")
    verification = None
    if req.verify:   # only when asked: the fast path does no extra work
        verification = verification_out(await compute.arun(
            verify_force_feedforward, dev, res, filt.order if filt else None, filt.cutoff_hz if filt else None,
            cost_ms=verify_cost_ms(dev)))
    return ForceFeedforwardResponse(
        critical_force_gain=kcr, crossover_frequency=res.crossover_frequency,
        crossovers=[{"frequency": c.frequency, "force_gain": c.force_gain} for c in res.crossovers],
        worst_case_force_gain=res.worst_case_force_gain,
        apparent_mass_at_critical=apparent_mass(dev, kcr) if kcr is not None else None,
        model="cable" if dev.cable else "rigid", rigid_critical_force_gain=rigid, rigid_optimistic=optimistic,
        human=res.human.model_dump(), human_source=res.human_source,
        force_sensor_time_constant=dev.force_sensor.time_constant if dev.force_sensor else 0.0,
        method=res.method, elapsed_ms=(time.perf_counter() - start) * 1e3, error_estimate=res.error_estimate,
        error_source=res.error_source, reason=res.reason, notes=notes, verification=verification)


@router.post("/v1/design/inertia", response_model=InertiaResponse)
async def inertia(req: InertiaRequest, compute: Compute) -> InertiaResponse:
    r = req.requirements
    spec = r.core()
    if r.uncertainty is not None:
        if req.method != "exact":
            raise InputError("method", "robust designs (requirements.uncertainty) are computed on the exact rung only")
        return await _robust_inertia(req, spec, compute)
    try:
        d, rung = await compute.arun(design_inertia_on_rung, req.device, spec, req.method, req.grid_points,
                                     cost_ms=inertia_design_cost_ms(
                                         req.device, req.method, req.grid_points,
                                         len(r.humans or ()) or (2 if r.human_mass_range else 1)))
    except ValueError as exc:
        raise _field_error(exc) from exc
    notes = _human_notes(d.human_source)
    jumps = d.solver.get("crossover_structure_changes_hz") or []
    if jumps and not isinstance(jumps[0], (list, tuple)):     # one [lo, hi] pair
        jumps = [jumps]
    if jumps:
        where = ", ".join(f"{lo:.4g}–{hi:.4g} Hz" for lo, hi in jumps[:3]) + (" …" if len(jumps) > 3 else "")
        notes.append(f"K_f,cr jumps at {where}, where two phase crossovers merge and vanish; a design next to a jump "
                     "is sensitive to model error (the lower crossover can return)")
    rigid = _rigid_out(d, notes, "the rigid model")
    verification = None
    if req.verify and d.force_gain is not None and math.isfinite(d.force_gain) and d.filter_cutoff_hz is not None:
        # the margin claims K_f,cr = K_f·10^(GM/20) for the worst grasp: check it and K_f itself on the closed loop
        human = d.worst_human or (d.humans[0] if d.humans else resolve_human(req.device)[0])
        gm = d.gain_margin_db
        critical = d.force_gain * 10 ** (gm / 20) if gm is not None and math.isfinite(gm) else d.critical_force_gain
        verification = verification_out(await compute.arun(
            verify_critical_force_gain, req.device, human, critical, d.filter_order, d.filter_cutoff_hz,
            claimed_epsilon(rung.method, rung.error_estimate), design_gain=d.force_gain,
            cost_ms=verify_cost_ms(req.device)))
    return InertiaResponse(
        status=d.status, objective=d.objective, force_gain=d.force_gain,
        filter_cutoff_hz=d.filter_cutoff_hz, filter_order=d.filter_order, apparent_mass=d.apparent_mass,
        critical_force_gain=d.critical_force_gain, gain_margin_db=d.gain_margin_db,
        crossover_frequency=d.crossover_frequency, cutoff_band_hz=d.cutoff_band_hz,
        cutoff_max_source=d.cutoff_max_source,
        pareto=_pareto_out(d),
        humans=[h.model_dump() for h in d.humans],
        worst_human=d.worst_human.model_dump() if d.worst_human else None, human_source=d.human_source,
        rigid_model=rigid, solver={k: v for k, v in d.solver.items()}, reason=d.reason, notes=notes,
        elapsed_ms=d.elapsed_ms, verification=verification, **rung_fields(rung))


def _pareto_out(d) -> list[dict]:
    """The design's exact scan of the band, non-finite values as null."""
    return [{"filter_cutoff_hz": p.filter_cutoff_hz, "critical_force_gain": p.critical_force_gain,
             "force_gain": p.force_gain, "apparent_mass": p.apparent_mass} for p in d.pareto]


def _rigid_out(d, notes: list[str], who: str) -> dict | None:
    """The design's rigid-model comparison as the response's dict; a note when the rigid model over-promises."""
    rm = d.rigid_model
    if rm is None:
        return None
    if rm.optimistic:
        notes.append(f"{who} is optimistic: it claims K_f,cr = {rm.critical_force_gain:.4g} at this cutoff, "
                     f"{100 * rm.optimism:.0f} % above the cable model's {d.critical_force_gain:.4g}")
    return {"critical_force_gain": rm.critical_force_gain, "force_gain": rm.force_gain,
            "optimism": rm.optimism, "optimistic": rm.optimistic}


async def _robust_inertia(req: InertiaRequest, spec: InertiaRequirements, compute: Compute) -> InertiaResponse:
    from optim.robust.box import UncertaintyBox
    from optim.robust.inertia import robust_design_inertia
    from optim.verification_robust import verify_robust_inertia

    from .design_stiffness import input_error

    try:
        box = UncertaintyBox.from_ranges(req.device, {k: (v.min, v.max) for k, v in req.requirements.uncertainty.items()})
        d = await compute.arun(robust_design_inertia, req.device, spec, box, cost_ms=None)  # always a worker
    except InputError as exc:
        raise input_error(exc) from None
    except ValueError as exc:
        raise _field_error(exc) from None
    human, source = resolve_human(req.device)
    notes = _human_notes(source)
    if d.pareto:
        notes.append("pareto: K_f,cr at each cutoff is the worst over the scenarios (the box's corners, its nominal "
                     "device and the worst devices the search added); only the design's cutoff is verified over the "
                     "whole box")
    rigid = _rigid_out(d, notes, "the rigid model of the worst device")
    verification = None
    if req.verify and d.status == "optimal" and d.force_gain is not None and d.filter_cutoff_hz is not None:
        # every corner of the box and the worst device found, on the closed loop
        verification = verification_out(await compute.arun(
            verify_robust_inertia, box, d.force_gain, d.filter_cutoff_hz, d.filter_order, spec.min_gain_margin_db,
            (d.worst_case or {}).get("device"), cost_ms=None))
    return InertiaResponse(
        status=d.status, objective=d.objective, force_gain=d.force_gain, filter_cutoff_hz=d.filter_cutoff_hz,
        filter_order=d.filter_order, apparent_mass=d.apparent_mass,
        critical_force_gain=d.critical_force_gain, gain_margin_db=d.gain_margin_db,
        crossover_frequency=(d.worst_case or {}).get("crossover_frequency"),
        cutoff_band_hz=d.cutoff_band_hz or (spec.cutoff_min_hz, spec.cutoff_min_hz),
        cutoff_max_source="requirements" if spec.cutoff_max_hz is not None else
        "lowest first cable mode (eq. 24) or 0.4 × Nyquist over the box's corners",
        pareto=_pareto_out(d),
        humans=[human.model_dump()], worst_human=None, human_source=source, rigid_model=rigid,
        solver=dict(d.solver), reason=d.reason, notes=notes, elapsed_ms=d.elapsed_ms, robust=True,
        worst_case=d.worst_case, nominal_gain_margin_db=d.nominal_gain_margin_db,
        apparent_mass_range=d.apparent_mass_range, scenarios=list(d.scenarios), iterations=d.iterations,
        evaluations=d.evaluations, verification=verification)
