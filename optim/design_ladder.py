"""Stiffness and inertia designs on every rung of the accuracy ladder (issue 6: "every design accepts method").

A thin dispatcher: ``exact`` is the existing design (optim.stiffness, optim.transparency.inertia),
untouched.  The other rungs:

* ``linear`` — the closed-form design.  Stiffness: maximise K ≤ 10^(−GM/20)·(b + B)/(T/2 + t_d)
  (eq. 10) under the limits; eq. 10 grows without bound in B, so without a damping or
  stiffness limit the answer is ``infeasible`` with that reason (no B is invented).  With
  passivity it uses the closed-form sufficient condition b ≥ K·(T/2 + d_p·T) + B (the
  delayed Colgate–Schenkel form of ARCHITECTURE.md bounded term by term; eq. 3 at d = 0).
  Inertia: K_f,cr ≈ 1 + m/m_h (eq. 33) for the heaviest grasp; eq. 33 does not depend on
  the filter, so the rung keeps the widest cutoff of the band.
* ``grid`` — a dense scan of B (201 values on [0, B_max) with B_max from the same grid)
  or of the cutoff (201 values over the band) with the grid rung's K_cr / K_f,cr.
* ``reference`` — the exact design re-verified by the 40-digit reference at the
  design's B (or cutoff and worst grasp); the error bound is the gap between them.

The approximate rungs (linear, grid) report the *exact* analysis of the design they
produced beside it (``exact_check``): a user must see when a closed-form design is
actually unsafe.  A design that fails its own exact check (margin below the requirement,
unstable, or not passive when passivity is required) is not ``optimal``: its status is
``unsafe`` and its ``reason`` gives the exact margin; the top-level fields stay the
rung's own (what the rung computed), the exact ones are in ``exact_check``.  Each
answer says its rung, cost, error estimate and where that estimate comes from.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np

from models.device import Device, Human
from models.filters import ButterworthLowPass
from optim.errors import InputError
from optim.solver_info import SolverInfo
from optim.stability.analysis import (
    DEFAULT_GRID_POINTS,
    check_rung,
    grid_critical_stiffness,
    linear_error_estimate,
)
from optim.stability.margins import critical_stiffness, gain_margin_db, linear_estimate, loop_plant
from optim.stability.passivity import passive_alpha_on_grid, passivity_margin, passivity_samples
from optim.stability.reference import reference_critical_stiffness
from optim.stiffness import StiffnessDesign, StiffnessRequirements, design_stiffness
from optim.transparency.feedforward import critical_force_gain
from optim.transparency.feedforward_ladder import grid_critical_force_gain, linear_force_gain_error
from optim.transparency.feedforward_loop import cutoff_band, design_humans
from optim.transparency.feedforward_reference import REFERENCE_DIGITS, reference_critical_force_gain
from optim.transparency.inertia import InertiaDesign, InertiaRequirements, design_inertia

__all__ = ["ExactCheck", "RungInfo", "design_stiffness_on_rung", "design_inertia_on_rung", "DESIGN_SCAN_POINTS"]

#: B values (or cutoffs) of the grid rung's design scan.
DESIGN_SCAN_POINTS = 201
_REF_ERR = 10.0 ** (-(REFERENCE_DIGITS - 5))
_EXACT_ERR = 1e-12


@dataclass(frozen=True)
class ExactCheck:
    """The exact analysis of an approximate rung's design."""

    critical_value: float | None
    """exact K_cr(B) [N/m] or K_f,cr at the design's cutoff [dimensionless]; None when not finite."""
    gain_margin_db: float | None
    """exact 20·log10(critical/design) [dB]; None when the design is unstable at any gain (critical 0)."""
    meets_min_gain_margin: bool
    stable: bool
    passive: bool | None = None
    """exact delayed passivity of (K, B) (stiffness designs with passivity required)."""
    statement: str = ""

    @property
    def safe(self) -> bool:
        """the design meets its margin requirement and (when required) is passive, by the exact analysis."""
        return self.meets_min_gain_margin and self.passive is not False


def exact_check(critical: float, value: float, required_db: float, what: str,
                passive: bool | None = None) -> ExactCheck:
    """The ExactCheck of a design's value against its exact critical value (the rendered designs' label too)."""
    return _exact_check(critical, value, required_db, what, passive)


def _unsafe_reason(method: str, check: ExactCheck) -> str:
    return (f"the {method} rung's design fails its own exact check: {check.statement.removeprefix('UNSAFE: ')} "
            "(its top-level margin is the rung's estimate; exact_check has the exact analysis)")


@dataclass(frozen=True)
class RungInfo:
    method: str
    error_estimate: float | None
    """relative error bound/estimate of the design's critical value (K_cr or K_f,cr), on which its margin rests."""
    error_source: str
    exact_check: ExactCheck | None = None
    elapsed_ms: float = 0.0


def _exact_check(critical: float, value: float, required_db: float, what: str, passive: bool | None = None) -> ExactCheck:
    gm = gain_margin_db(critical, value) if critical > 0 and math.isfinite(critical) else None
    if math.isinf(critical):
        gm = None
    stable = value < critical
    meets = (gm is not None and gm >= required_db * (1 - 1e-9) - 1e-12) or math.isinf(critical)
    ok = meets and passive is not False
    if ok:
        text = f"safe: the exact margin of this {what} is " + (f"{gm:.4g} dB" if gm is not None else "unbounded")
    else:
        text = (f"UNSAFE: the exact margin of this {what} is " + (f"{gm:.4g} dB" if gm is not None else "none")
                + f", below the required {required_db:g} dB" * (not meets)
                + ("; it is not passive" if passive is False else "") + (" — it is unstable" if not stable else ""))
    return ExactCheck(critical_value=critical if math.isfinite(critical) else None, gain_margin_db=gm,
                      meets_min_gain_margin=bool(meets), stable=bool(stable), passive=passive, statement=text)


# ================================================================ stiffness

def _stiffness_check(device: Device, req: StiffnessRequirements, k: float, b: float) -> ExactCheck:
    passive = passivity_margin(device, k, b).passive if req.passivity else None
    return _exact_check(critical_stiffness(device, b).critical_stiffness, k, req.min_gain_margin_db, "design",
                        passive)


def _linear_stiffness(device: Device, req: StiffnessRequirements) -> StiffnessDesign:
    g, b, tau = req.gain_factor, device.damping, device.sample_time / 2 + device.delay
    k_caps, b_caps = req.stiffness_caps(), req.damping_caps(device.sample_time)
    k_cap, b_cap = min(k_caps.values(), default=math.inf), min(b_caps.values(), default=math.inf)
    solver = SolverInfo("closed form (eq. 10)")
    if not req.passivity and math.isinf(k_cap) and math.isinf(b_cap):
        return StiffnessDesign(status="infeasible", solver=solver, reason=(
            "eq. 10, K < (b + B)/(T/2 + t_d), grows without bound in B: without max_damping (or quantization and "
            "max_force_noise) or a stiffness limit the closed-form design is unbounded; the exact boundary is not "
            "(use method exact)"))
    tau_p = device.sample_time / 2 + passivity_samples(device)[0] * device.sample_time
    if req.passivity and b <= 0:
        return StiffnessDesign(status="infeasible", solver=solver,
                               reason="passivity required but the device has no physical damping")

    def k_of(bb: float) -> float:
        ks = [g * (b + bb) / tau, k_cap] + ([(b - bb) / tau_p] if req.passivity else [])
        return min(ks)
    cands = [0.0, b_cap, k_cap * tau / g - b]
    if req.passivity:
        cands.append((b / tau_p - g * b / tau) / (g / tau + 1 / tau_p))   # K_stab(B) = K_pass(B)
    cands = sorted({c for c in cands if math.isfinite(c) and 0.0 <= c <= b_cap})
    best_b = max(cands, key=lambda c: (k_of(c), -c))
    k = k_of(best_b)
    if not k > 0:
        return StiffnessDesign(status="infeasible", solver=solver,
                               reason="the closed-form conditions leave no positive stiffness")
    kcr = linear_estimate(device, best_b)
    rt = 1 - 1e-9
    active = (["min_gain_margin_db"] * bool(k >= g * kcr * rt)
              + ["passivity"] * bool(req.passivity and k >= (b - best_b) / tau_p * rt))
    active += [n for n, c in k_caps.items() if k >= c * rt] + [n for n, c in b_caps.items() if best_b >= c * rt]
    return StiffnessDesign(status="optimal", stiffness=k, damping=best_b, critical_stiffness=kcr,
                           gain_margin_db=gain_margin_db(kcr, k), crossover_frequency=math.sqrt(kcr / device.mass),
                           linear_estimate=kcr, linear_estimate_error=None, active_constraints=tuple(active),
                           solver=solver, passivity_delay_samples=passivity_samples(device)[0] if req.passivity else None,
                           passivity_note=("closed-form sufficient condition b ≥ K(T/2 + d_p T) + B" if req.passivity
                                           else None))


def _grid_kcr_rows(device: Device, betas: np.ndarray, points: int) -> np.ndarray:
    """Dimensionless grid K_cr for many β at once (same grid and interpolation as analysis.grid_critical_stiffness)."""
    plant = loop_plant(device)
    theta = np.geomspace(1e-3, math.pi, points)
    h = -plant.inverse_response(theta)[None, :] + betas[:, None] * np.expm1(-1j * theta)[None, :]
    im, re = h.imag, h.real
    cross = np.sign(im[:, :-1]) * np.sign(im[:, 1:]) < 0
    with np.errstate(divide="ignore", invalid="ignore"):
        w = im[:, :-1] / (im[:, :-1] - im[:, 1:])
    k = re[:, :-1] + w * (re[:, 1:] - re[:, :-1])
    k = np.where(cross & (k > 0), k, np.inf).min(axis=1)
    k = np.minimum(k, np.where(re[:, -1] > 0, re[:, -1], np.inf))
    # without any damping (δ = β = 0) the crossover is at θ → 0⁺ with K → 0, below the grid (analysis.py likewise)
    return np.where(device.delta + betas <= 0.0, 0.0, k)


def _grid_max_damping(device: Device, points: int) -> float:
    """β_max of the damper-only loop on the same grid (inf when it has no crossing)."""
    plant = loop_plant(device)
    theta = np.geomspace(1e-3, math.pi, points)
    h = -plant.inverse_response(theta) / (-np.expm1(-1j * theta))
    im, re = h.imag, h.real
    i = np.nonzero(np.sign(im[:-1]) * np.sign(im[1:]) < 0)[0]
    w = im[i] / (im[i] - im[i + 1])
    k = re[i] + w * (re[i + 1] - re[i])
    vals = list(k[k > 0]) + ([re[-1]] if re[-1] > 0 else [])
    return float(min(vals)) if vals else math.inf


def _grid_stiffness(device: Device, req: StiffnessRequirements, points: int) -> tuple[StiffnessDesign, float]:
    ks, bs = device.stiffness_scale, device.damping_scale
    k_caps, b_caps = req.stiffness_caps(), req.damping_caps(device.sample_time)
    k_cap, b_cap = min(k_caps.values(), default=math.inf), min(b_caps.values(), default=math.inf)
    solver = SolverInfo(f"B scan ({DESIGN_SCAN_POINTS} values) × frequency grid ({points} points)")
    beta_max = _grid_max_damping(device, points)
    b_max = beta_max * bs
    upper = min(b_max, b_cap)
    if not math.isfinite(upper):
        return StiffnessDesign(status="infeasible", solver=solver, reason="the damper-only loop has no crossover on "
                               "the grid and no max_damping was given: the design is unbounded in B"), math.inf
    betas = np.linspace(0.0, upper / bs, DESIGN_SCAN_POINTS)
    if upper >= b_max:
        betas = betas[:-1]                      # K_cr = 0 at B_max itself
    obj = np.minimum(req.gain_factor * _grid_kcr_rows(device, betas, points), k_cap / ks)
    d_pass = passivity_samples(device)[0]
    if req.passivity:
        obj = np.minimum(obj, passive_alpha_on_grid(device.delta, d_pass, betas)[0])
    i = int(np.argmax(obj))
    if not obj[i] > 0:
        return StiffnessDesign(status="infeasible", solver=solver, max_stable_damping=b_max,
                               reason="no positive stiffness meets the requirements at any scanned B"), math.inf
    if not math.isfinite(obj[i]):
        return StiffnessDesign(status="infeasible", solver=solver, reason="every positive stiffness is stable on the "
                               "grid and no stiffness limit was given: the design is unbounded"), math.inf
    b = float(betas[i]) * bs
    k = float(obj[i]) * ks
    kcr, w, _, err = grid_critical_stiffness(device, b, points)
    rt = 1 - 1e-9
    active = ["min_gain_margin_db"] * bool(k >= req.gain_factor * kcr * rt) + [n for n, c in k_caps.items() if k >= c * rt]
    active += [n for n, c in b_caps.items() if b >= c * rt]
    if req.passivity and "min_gain_margin_db" not in active and not any(n in active for n in k_caps):
        active.append("passivity")
    lin = linear_estimate(device, b)
    return StiffnessDesign(status="optimal", stiffness=k, damping=b, critical_stiffness=kcr,
                           gain_margin_db=gain_margin_db(kcr, k), crossover_frequency=w, linear_estimate=lin,
                           linear_estimate_error=(lin - kcr) / kcr, max_stable_damping=b_max if math.isfinite(b_max)
                           else None, active_constraints=tuple(active), solver=solver,
                           passivity_delay_samples=d_pass if req.passivity else None), err


def _rendered_design(device: Device, req: StiffnessRequirements, method: str, mass: float,
                     velocity_filter) -> tuple[StiffnessDesign, RungInfo]:
    """A rendered wall's design (optim.stiffness.rendered_design) with its exact check (optim.stiffness.rendered_check)
    deciding the label."""
    from optim.stiffness.rendered_check import rendered_exact_check
    from optim.stiffness.rendered_design import design_rendered_stiffness

    if method != "exact":
        raise InputError("method", "designs of a rendered wall (a velocity filter, a designed cutoff or a virtual "
                                   "mass) are computed on the exact rung only")
    t0 = time.perf_counter()
    design = design_rendered_stiffness(device, req, mass, velocity_filter)
    check = None
    if design.status == "optimal" and design.rendered is not None:
        check = rendered_exact_check(device, req, design, velocity_filter)
        if not check.safe:
            design = replace(design, status="unsafe", reason=(
                f"the rendered design fails its exact check: {check.statement.removeprefix('UNSAFE: ')}"))
    elapsed = (time.perf_counter() - t0) * 1e3
    design = replace(design, elapsed_ms=elapsed)
    src = ("exact rendered boundary: K_cr re-checked at the design's B and filter by the exact rendered analysis "
           "(optim.stability.rendered), passivity by the general Colgate–Schenkel scan, the noise rules recomputed")
    return design, RungInfo(method, _EXACT_ERR, src, check, elapsed)


def is_rendered(req: StiffnessRequirements, mass: float = 0.0, velocity_filter=None) -> bool:
    """Whether a design renders more than today's wall C(z) = K + B(1 − z⁻¹)/T."""
    spec = velocity_filter if velocity_filter is not None else req.velocity_filter
    return mass != 0.0 or (spec is not None and getattr(spec, "kind", None) != "backward_difference")


def design_stiffness_on_rung(device: Device, req: StiffnessRequirements | None = None, method: str = "exact",
                             grid_points: int = DEFAULT_GRID_POINTS, mass: float = 0.0,
                             velocity_filter=None) -> tuple[StiffnessDesign, RungInfo]:
    """The stiffness design on one rung, with the rung's error estimate and (linear, grid) the exact check.  A
    virtual mass M [kg] or a velocity filter (``velocity_filter``, or ``req.velocity_filter`` — fixed or a designed
    cutoff) makes it a rendered design (exact rung only, its label decided by the exact rendered check)."""
    check_rung(method, grid_points)
    req = req or StiffnessRequirements()
    if is_rendered(req, mass, velocity_filter):
        return _rendered_design(device, req, method, mass, velocity_filter)
    t0 = time.perf_counter()
    check = None
    if method == "linear":
        design = _linear_stiffness(device, req)
        err = linear_error_estimate(device, design.damping) if design.status == "optimal" else None
        src = ("eq. 10's error at the design's B (the linear rung's estimate, optim.stability.analysis); the exact margin "
               "of the design is in exact_check")
    elif method == "grid":
        design, err = _grid_stiffness(device, req, grid_points)
        err = err if design.status == "optimal" else None
        src = ("grid K_cr error at the chosen B (the whole change of K across the bracketing interval; null when the grid cannot see every crossover); the B scan "
               "may also miss the optimum by one B step")
    else:
        design = design_stiffness(device, req)
        err, src = _EXACT_ERR, "exact boundary; K_cr re-checked by the exact analysis (1e-12 against the reference)"
        if method == "reference" and design.status == "optimal":
            ref = reference_critical_stiffness(device, design.damping)
            gap = abs(design.critical_stiffness / ref.critical_stiffness - 1) if ref.critical_stiffness > 0 else math.inf
            design = replace(design, critical_stiffness=ref.critical_stiffness,
                             gain_margin_db=gain_margin_db(ref.critical_stiffness, design.stiffness),
                             crossover_frequency=ref.crossover_frequency)
            err = gap + _REF_ERR
            src = (f"the exact design re-verified at its B by the {ref.digits}-digit reference: the bound is the gap "
                   "between the exact and the reference K_cr")
        elif method == "reference":
            err, src = None, "no design to verify"
    if method in ("linear", "grid") and design.status == "optimal":
        check = _stiffness_check(device, req, design.stiffness, design.damping)
        if not check.safe:
            design = replace(design, status="unsafe", reason=_unsafe_reason(method, check))
    elapsed = (time.perf_counter() - t0) * 1e3
    design = replace(design, elapsed_ms=elapsed)
    return design, RungInfo(method, err, src, check, elapsed)


# ================================================================ inertia

def _heaviest(device: Device, humans: list[Human]) -> Human:
    """The grasp with the smallest 1 + m/m_h (eq. 33's worst case): the heaviest hand."""
    return max(humans, key=lambda h: h.mass)


def _exact_force_gain(device: Device, humans: list[Human], filt: ButterworthLowPass) -> tuple[float, Human]:
    res = [(critical_force_gain(device, filt, h).critical_force_gain, h) for h in humans]
    return min(res, key=lambda r: r[0])


def _inertia_answer(device, req, humans, human_src, lo, hi, src, kf, cutoff, kcr, worst, solver, status="optimal",
                    reason=None) -> InertiaDesign:
    objective = "target_apparent_mass" if req.target_apparent_mass is not None else "min_apparent_mass"
    ok = kf is not None and kf > 0 and kcr is not None and math.isfinite(kcr)
    return InertiaDesign(status=status, objective=objective, force_gain=kf, filter_cutoff_hz=cutoff,
                         filter_order=req.filter_order, apparent_mass=device.mass / (1 + kf) if kf is not None else None,
                         critical_force_gain=kcr, gain_margin_db=20 * math.log10(kcr / kf) if ok else None,
                         crossover_frequency=None, cutoff_band_hz=(lo, hi), cutoff_max_source=src, pareto=(),
                         humans=tuple(humans), worst_human=worst, human_source=human_src, rigid_model=None,
                         solver=solver, reason=reason)


def _choose_force_gain(device, req, kcr_best: float, rho: float) -> tuple[float | None, str | None]:
    if req.target_apparent_mass is None:
        return kcr_best / rho, None
    kf = device.mass / req.target_apparent_mass - 1.0
    if kf <= 0:
        return None, (f"target_apparent_mass {req.target_apparent_mass:g} is not below the device's mass "
                      f"{device.mass:g}: force feedforward only lowers the apparent mass")
    if rho * kf > kcr_best:
        return None, (f"K_f = {kf:.6g} needs K_f,cr ≥ {rho * kf:.6g} for {req.min_gain_margin_db:g} dB; this rung "
                      f"finds at most {kcr_best:.6g}")
    return kf, None


def design_inertia_on_rung(device: Device, req: InertiaRequirements | None = None, method: str = "exact",
                           grid_points: int = DEFAULT_GRID_POINTS) -> tuple[InertiaDesign, RungInfo]:
    """The inertia design (K_f, cutoff) on one rung; linear and grid carry the exact check at their cutoff."""
    check_rung(method, grid_points)
    req = req or InertiaRequirements()
    t0 = time.perf_counter()
    if method in ("exact", "reference"):
        design = design_inertia(device, req)
        err, src, check = _EXACT_ERR, "exact K_f,cr at the design's cutoff (1e-12 against the reference)", None
        if method == "reference" and design.status == "optimal":
            filt = ButterworthLowPass(design.filter_order, design.filter_cutoff_hz, device.sample_time)
            ref = reference_critical_force_gain(device, design.worst_human, filt.order, filt.cutoff_hz)
            gap = abs(design.critical_force_gain / ref.critical_force_gain - 1)
            design = InertiaDesign(**{**design.__dict__, "critical_force_gain": ref.critical_force_gain,
                                      "gain_margin_db": 20 * math.log10(ref.critical_force_gain / design.force_gain),
                                      "crossover_frequency": ref.crossover_frequency})
            err = gap + _REF_ERR
            src = (f"the exact design re-verified at its cutoff for its worst grasp by the {ref.digits}-digit "
                   "reference: the bound is the gap between the exact and the reference K_f,cr")
        elif method == "reference":
            err, src = None, "no design to verify"
    else:
        lo, hi, band_src = cutoff_band(device, req)
        humans, human_src = design_humans(device, req)
        rho = 10 ** (req.min_gain_margin_db / 20)
        if method == "linear":
            worst = _heaviest(device, humans)
            kcr_lin = 1.0 + device.mass / worst.mass
            cutoff = hi                 # eq. 33 does not see the filter: keep the widest force bandwidth
            kf, why = _choose_force_gain(device, req, kcr_lin, rho)
            filt = ButterworthLowPass(req.filter_order, cutoff, device.sample_time)
            solver = SolverInfo("closed form (eq. 33)")
            design = _inertia_answer(device, req, humans, human_src, lo, hi, band_src, kf, cutoff if kf else None,
                                     kcr_lin, worst, solver, "optimal" if kf else "infeasible", why)
            err = linear_force_gain_error(device, worst, filt)
            src = ("eq. 33's error at the design's cutoff for the heaviest grasp (optim.transparency.feedforward_ladder); the "
                   "exact margin of the design is in exact_check")
        else:
            cutoffs = np.geomspace(lo, hi, DESIGN_SCAN_POINTS)
            rows = []
            for c in cutoffs:
                f = ButterworthLowPass(req.filter_order, float(c), device.sample_time)
                rows.append(min((grid_critical_force_gain(device, h, f, grid_points) + (h,) for h in humans),
                                key=lambda r: r[0]))
            kcrs = np.array([r[0] for r in rows])
            if req.target_apparent_mass is None:
                j = int(np.argmax(kcrs))
            else:
                kf_t = device.mass / req.target_apparent_mass - 1.0
                ok = np.nonzero(kcrs >= rho * kf_t)[0]
                j = int(ok[-1]) if ok.size else int(np.argmax(kcrs))
            kf, why = _choose_force_gain(device, req, float(kcrs[j]), rho)
            solver = SolverInfo(f"cutoff scan ({DESIGN_SCAN_POINTS} values) × frequency grid ({grid_points} points)")
            design = _inertia_answer(device, req, humans, human_src, lo, hi, band_src, kf,
                                     float(cutoffs[j]) if kf else None, float(kcrs[j]), rows[j][4],
                                     solver, "optimal" if kf else "infeasible", why)
            err = rows[j][3]
            src = "grid K_f,cr error at the chosen cutoff (half the change across the bracketing interval)"
        check = None
        if design.status == "optimal":
            filt = ButterworthLowPass(req.filter_order, design.filter_cutoff_hz, device.sample_time)
            kx, _ = _exact_force_gain(device, humans, filt)
            check = _exact_check(kx, design.force_gain, req.min_gain_margin_db, "design")
            if not check.safe:
                design = InertiaDesign(**{**design.__dict__, "status": "unsafe",
                                          "reason": _unsafe_reason(method, check)})
    elapsed = (time.perf_counter() - t0) * 1e3
    design = InertiaDesign(**{**design.__dict__, "elapsed_ms": elapsed})
    return design, RungInfo(method, err, src, check, elapsed)
