"""Stability analysis of a wall on a device, on any rung of the accuracy ladder.

Rungs (ARCHITECTURE.md): ``linear`` (chapter eq. 9/10), ``grid`` (fixed frequency
grid), ``exact`` (every crossover bracketed and refined, optim.stability.margins),
``reference`` (40-digit mpmath, optim.stability.reference).  Every answer says which rung
produced it, what it cost and how far it may be off.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import Annotated, Literal, cast, get_args

import numpy as np
from pydantic import Field, TypeAdapter, ValidationError

from models.device import Device
from models.plants import Q_criterion
from models.velocity_filter import Rendering
from optim.domain import check_controller_domain
from optim.errors import NOT_REPRESENTABLE, InputError, from_validation
from optim.stability.crossovers import LOG_MIN_SAMPLES, LOG_PER_DECADE, refine_grid, theta_min
from optim.stability.margins import (
    NO_DAMPING_REASON,
    Crossover,
    critical_stiffness,
    gain_margin_db,
    linear_estimate,
    loop_plant,
    max_stable_damping,
)
from optim.stability.near_b_max import (
    B_MAX_SENSITIVITY,
    MEASURE_WITHIN,
    RHO_REFINE,
    ROUNDING,
    b_max_sensitivity,
    cancellation_ratio,
    input_conditioning,
    refine_cable_crossover,
)
from optim.stability.passivity import passivity_margin
from optim.stability.passivity_rendered import rendered_passivity
from optim.stability.reference import REFERENCE_STIFFNESS_MAX_DELAY_SAMPLES, reference_critical_stiffness
from optim.stability.rendered import MassRange, rendered_critical_stiffness, rendered_mass_range
from optim.stability.stable_band import StableBand, stable_band

__all__ = ["Method", "METHODS", "GridPoints", "MIN_GRID_POINTS", "check_rung", "StabilityAnalysis", "analyse_stability", "linear_error_estimate",
           "grid_critical_stiffness", "grid_blind_spot", "DEFAULT_GRID_POINTS", "MAX_GRID_POINTS", "EXACT_REL_ERROR",
           "MODE_MATTERS_RTOL"]

Method = Literal["linear", "grid", "exact", "reference"]
METHODS: tuple[str, ...] = get_args(Method)
DEFAULT_GRID_POINTS = 1000
#: Fewest frequency samples of the grid rung.
MIN_GRID_POINTS = 10
#: Cost limit of the grid rung.
MAX_GRID_POINTS = 1_000_000
#: Frequency samples of the grid rung: the one rule for every analysis and design, in optim and in the HTTP
#: requests (service.schemas.ladder), with one message.
GridPoints = Annotated[int, Field(ge=MIN_GRID_POINTS, le=MAX_GRID_POINTS)]
_RUNG_RULES = (("method", TypeAdapter(Method)), ("grid_points", TypeAdapter(GridPoints)))

#: the exact rung's claimed relative error: agreement with the 40-digit reference on the test suite
EXACT_REL_ERROR = 1e-12
#: the cable mode matters when it moves K_cr by more than this relative to the rigid model's
MODE_MATTERS_RTOL = 0.05


@dataclass(frozen=True)
class StabilityAnalysis:
    critical_stiffness: float | None
    """K_cr(B) [N/m]; 0 when the loop is unstable as K → 0⁺ (no damping, or B ≥ B_max: ``stable_band`` then says
    whether a larger K is stable); None when every K > 0 is."""
    crossover_frequency: float | None
    """ω [rad/s] of the crossover that sets K_cr."""
    crossovers: tuple[Crossover, ...]
    damping: float
    """B [N·s/m] of the analysed wall."""
    stiffness: float | None
    """K [N/m] of the analysed wall, when given."""
    gain_margin_db: float | None
    """20·log10(K_cr/K) [dB] when a stiffness is given (eq. 13/21)."""
    stable: bool | None
    passive: bool | None
    passivity_required_damping: float | None
    """max over θ of the delayed Colgate–Schenkel bound [N·s/m]; passive when b exceeds it."""
    passivity_conservative: bool
    linear_estimate: float
    """(b + B)/(T/2 + t_d) [N/m], chapter eq. 10."""
    linear_error: float | None
    """|linear/K_cr − 1| against this answer's K_cr."""
    max_stable_damping: float | None
    q_criterion: float | None
    """Q ≈ m_r z_n ω_n [N/m], eq. 22 (cable devices)."""
    mode_matters: bool | None
    """Cable devices: True when the exact cable K_cr differs from the rigid model's by more than 5 %."""
    rigid_critical_stiffness: float | None
    method: Method
    elapsed_ms: float
    """Wall time [ms] of the analysis itself, in the calling thread: from after the input checks (method,
    grid_points, stiffness, damping) to the answer (the rung's K_cr and every crossover, margin, stability,
    passivity, the cable's rigid K_cr, B_max, the linear estimate and its error); this record's construction and
    anything the caller does (HTTP parsing, validation, serialisation) excluded."""
    error_estimate: float
    """Relative error bound or estimate of critical_stiffness."""
    error_source: str
    reason: str | None
    stable_band: tuple[float, float] | None = None
    """[K_lo, K_hi] [N/m] (K_hi may be inf): where K_cr = 0 because B ≥ B_max, the stiffnesses the closed loop is
    nevertheless stable at (optim.stability.stable_band: a band not starting at 0); None when there is none or
    K_cr > 0 (the stable set is then 0 < K < K_cr)."""
    mass_range: MassRange | None = None
    """The stable virtual masses at (K, B) and this filter [kg] (asked with a rendering and a stiffness, exact rung;
    None when the wall is unstable at its own M)."""


def linear_error_estimate(device: Device, damping: float) -> float:
    """Relative error of eq. 10 against the exact K_cr, as an honest estimate.

    First order in (δ + β) with the delay's weight (the chapter's linearisation
    drops O((1+d)(δ+β)) terms), plus the second-order term that dominates in the
    curved part of the boundary (Fig. 9).  Its constants were fitted on rigid
    devices and are checked by tests/optim/stability/test_analysis.py and the accuracy
    benchmark: the true error stays within 2× of it.
    """
    delta = device.delta
    beta = damping / device.damping_scale
    d = device.delay_samples
    x = beta * (1 + 2 * d)
    rigid = delta * (1 + d) / 6 + beta * (1 + (1 + 2 * d) / 6) + x * x / 12
    # Eq. 10 grows with B while the exact K_cr collapses to 0 at B_max (the damper-only loop's limit,
    # x_max = β_max(1+2d) = 2 at d = 0 rising towards π: 2.49, 2.90, 3.16, 3.30 at d = 1, 5, 55, 200).
    # x0 = π − (π − 2)/√(1+d) stays below x_max, so dividing by (1 − x/x0) grows the estimate before the
    # collapse does (without it the true error reached 2.15× the estimate at B = 0.8·B_max, d = 5).
    x0 = math.pi - (math.pi - 2.0) / math.sqrt(1.0 + d)
    rigid /= max(1.0 - x / x0, 1e-3)
    if device.cable is None:
        return rigid
    # eq. 10 ignores the cable mode; the chapter's own test (eq. 22-24) compares Q with K_lin:
    # the resonant peak can move K_cr by about K_lin/Q; an undamped mode (Q = 0) has an unbounded peak.
    q = Q_criterion(device)
    return rigid + linear_estimate(device, damping) / q if q > 0 else math.inf


def grid_critical_stiffness(device: Device, damping: float, points: int) -> tuple[float, float | None, tuple[Crossover, ...], float]:
    """K_cr on a fixed log grid of ω from 1e-3/T to π/T (no refinement), as a naive tool would.

    Returns (K_cr, ω, crossovers, error estimate).  Linear interpolation of Im H
    between samples; its error is bounded by the whole change of Re H across the bracket (the crossing lies in
    it; half of it understated a rigid device at 5.6e-5 against 5.1e-5).
    The estimate is ∞ (unbounded: the grid cannot vouch for its answer) when the grid shows
    that it missed crossovers (see ``grid_unresolved``), and when B ≥ B_max (exact), where no K > 0 is stable.
    """
    if device.damping + damping <= 0.0:
        return 0.0, None, (), 0.0          # no damping at all: K_cr = 0 (the crossover at θ → 0⁺, below the grid)
    plant = loop_plant(device)
    beta = damping / device.damping_scale
    theta = np.geomspace(1e-3, math.pi, points)
    h = -plant.inverse_response(theta) + beta * np.expm1(-1j * theta)
    im, re = h.imag, h.real
    idx = np.nonzero((np.sign(im[:-1]) * np.sign(im[1:]) < 0))[0]
    found = []
    errs = []
    for i in idx:
        w = im[i] / (im[i] - im[i + 1])
        k = re[i] + w * (re[i + 1] - re[i])
        if k > 0:
            found.append(Crossover(frequency=(theta[i] + w * (theta[i + 1] - theta[i])) / device.sample_time,
                                   stiffness=k * device.stiffness_scale))
            # the crossing lies in the bracket: the whole change of Re H across it, plus the second differences
            # on both sides (Re H is curved near a delay-dominated crossover, so the chord's range can miss it:
            # 5.6e-5 true against 3.5e-5 from the change alone, on 346 samples of delay)
            curve = sum(abs(re[j + 1] - 2.0 * re[j] + re[j - 1]) for j in (i, i + 1) if 0 < j < len(re) - 1)
            errs.append((abs(re[i + 1] - re[i]) + curve) / abs(k))
    if re[-1] > 0:
        found.append(Crossover(frequency=math.pi / device.sample_time, stiffness=float(re[-1]) * device.stiffness_scale))
        # the Nyquist sample is exact up to rounding: the grid claims no more than the exact rung (its value was
        # 1 ulp from the exact K_cr, outside an estimate of 0, on δ ≈ 2e3 in a probe of the whole δ domain)
        errs.append(EXACT_REL_ERROR)
    if not found:
        return math.inf, None, (), math.inf
    j = int(np.argmin([c.stiffness for c in found]))
    kcr = found[j].stiffness
    blind = grid_blind_spot(device, theta) is not None
    err = math.inf if blind or grid_unresolved(h, device.delta + beta, kcr / device.stiffness_scale) else errs[j]
    if math.isfinite(err) and _crossing_below(plant, device, beta, theta[0], kcr / device.stiffness_scale * (1 + err)):
        err = math.inf
    if damping > 0 and damping >= max_stable_damping(device):
        # At or above B_max no K > 0 is stable (K_cr = 0), yet a grid still finds positive crossings: its answer
        # is then unbounded, not "exact at the Nyquist sample" (1.8 % of a 10,000-device verify run said so).
        err = math.inf
    return kcr, found[j].frequency, tuple(found), err


def _crossing_below(plant, device: Device, beta: float, theta0: float, alpha: float) -> bool:
    """Whether a crossover with K below α (dimensionless) lies under the grid's lowest angle θ₀: H sampled on a log
    grid from the scan's lowest angle (optim.stability.crossovers.theta_min) to θ₀, refined where arg H turns.

    The parity test of ``grid_unresolved`` sees an odd number of them; an even number (the mass-damper crossover
    and one a broad cable mode puts there, neither mode below the grid itself) leaves it blind: a cable with
    k_c = 11.8 N/m, T = 0.24 ms and 388 samples of delay had crossovers at 6e-6 and 8.7e-4 rad per sample under
    θ₀ = 1e-3, K_cr 4.3e-4 N/m, and the grid answered 15.81 with a 1.1 % estimate (docs/properties_analysis.md)."""
    lo = float(theta_min(device.delta + beta, device.delay_samples))
    if lo >= theta0:
        return False
    grid = np.geomspace(lo, theta0, max(LOG_MIN_SAMPLES, int(LOG_PER_DECADE * math.log10(theta0 / lo)) + 2))
    grid, h = refine_grid(lambda t: -plant.inverse_response(t) + beta * np.expm1(-1j * t), grid)
    im, re = h.imag, h.real
    change = (np.sign(im[:-1]) * np.sign(im[1:]) <= 0) & ((im[:-1] != 0) | (im[1:] != 0))
    # the crossing's K lies between the bracket's ends (refined: arg H turns < 0.25 rad across it)
    k_low = np.minimum(np.where(re[:-1] > 0, re[:-1], np.inf), np.where(re[1:] > 0, re[1:], np.inf))
    return bool(np.any(change & (k_low < alpha)))


def _modes(device: Device) -> list[tuple[float, float, str]]:
    """(angle, half-width) per sample of every lightly damped feature of G: the cable's resonance (poles of the
    continuous plant, sampled at e^{sT}) and anti-resonance (roots of m_d s² + (b_d + b_c) s + k_c), with the
    kind.  The rigid plant has none (its only pole besides z = 1 sits at angle 0)."""
    c = device.cable
    if c is None:
        return []
    plant = loop_plant(device)
    t = device.sample_time
    out = [(abs(s.imag), abs(s.real), "resonance") for s in np.linalg.eigvals(plant.a) if s.imag > 0]
    out += [(abs(s.imag) * t, abs(s.real) * t, "anti-resonance")
            for s in np.roots([c.body_mass, c.body_damping + c.damping, c.stiffness]) if s.imag > 0]
    return out


def grid_blind_spot(device: Device, theta: np.ndarray) -> str | None:
    """Why the grid θ (rad per sample, increasing) cannot see every crossover, from the device alone; None if it can.

    Below the grid's lowest angle θ₀, arg H rises monotonically from −π/2 (the mass-damper asymptote
    H ≈ θ² − j(δ+β)θ, turned by the delay's e^{jdθ}) unless a mode of the plant sits there: then at most one
    crossover hides below θ₀, which the parity test of ``grid_unresolved`` sees.  Two things break that:
    * the delay's phase (d + 1)·θ₀ reaching π: arg H can wind past 0 twice below the grid;
    * a resonance or anti-resonance (its swing of arg G by π) below the grid's second angle, or narrower than
      the grid's spacing where it sits: a pair of crossovers can hide there with the net phase unchanged
      between two samples (issue 17: a cable sampled at 62 µs answered 14,927 N/m with a 1.1 % estimate
      where the truth is 21 N/m).  Seen from the modal form, not from the samples.
    """
    if (device.delay_samples + 1.0) * theta[0] >= math.pi:
        return (f"the delay turns the phase by {(device.delay_samples + 1.0) * theta[0]:.3g} rad below the grid's "
                "lowest frequency: crossovers may hide there")
    for angle, width, kind in _modes(device):
        if angle <= theta[1]:
            return f"a cable {kind} at {angle / device.sample_time:.4g} rad/s lies below the grid's second frequency"
        if angle >= math.pi:
            continue
        i = min(int(np.searchsorted(theta, angle)), theta.size - 1)
        spacing = theta[i] - theta[i - 1]
        if width < spacing:
            return (f"a cable {kind} at {angle / device.sample_time:.4g} rad/s is narrower "
                    f"({width / device.sample_time:.3g} rad/s) than the grid's spacing there "
                    f"({spacing / device.sample_time:.3g} rad/s)")
    return None


def grid_unresolved(h: np.ndarray, damping_sum: float, alpha: float) -> bool:
    """Whether the grid's own samples show it may have missed a crossover below its answer α (dimensionless).

    * parity below the grid: for θ → 0⁺, Im H ≈ −(δ + β)·θ < 0 (the mass-damper asymptote of every device
      here); Im H > 0 at the lowest sample means an odd number of crossovers lie below the grid (the trap of
      FIELD-NOTES: the first one sits near sqrt((δ+β)/(d+½)), below 1e-3 rad/sample for tiny δ);
    * between samples: arg H turning by more than π/2 from one sample to the next, where Re H is positive and
      below α at either end, can hide a pair of crossovers with K below the answer (the delay's phase d·Δθ).
    """
    if damping_sum > 0 and h[0].imag > 0:
        return True
    turn = np.abs(np.angle(h[1:] / h[:-1]))
    low = ((h.real[:-1] > 0) & (h.real[:-1] < alpha)) | ((h.real[1:] > 0) & (h.real[1:] < alpha))
    return bool(np.any((turn > math.pi / 2) & low))


def _finite(x: float | None) -> float | None:
    return None if x is None or not math.isfinite(x) else x


def analyse_stability(device: Device, stiffness: float | None = None, damping: float = 0.0,
                      method: str = "exact", grid_points: int = DEFAULT_GRID_POINTS,
                      rendering: Rendering | None = None) -> StabilityAnalysis:
    """K_cr(B) of the device on the chosen rung, and the margin, stability and passivity of (K, B).

    ``rendering``: the wall's velocity filter and virtual mass (models.velocity_filter); None is today's wall
    C(z) = K + B(1 − z⁻¹)/T.  Given (even the default), a stiffness also gets its ``mass_range``.  Any other than
    the default is analysed on the exact rung only (InputError naming ``method`` otherwise).

    Raises ValueError (naming the field) for inputs the numerics cannot represent: an
    overflow or an invalid operation is never turned into a NaN answer.
    """
    try:
        with np.errstate(over="raise", invalid="raise"):
            if rendering is not None:
                return _analyse_rendered(device, stiffness, damping, method, grid_points, rendering)
            return _analyse(device, stiffness, damping, method, grid_points)
    except (FloatingPointError, OverflowError, ZeroDivisionError) as exc:
        raise InputError("device", NOT_REPRESENTABLE) from exc


@dataclass(frozen=True)
class RungAnswer:
    """What one rung says about K_cr(B), before the wall's margin, stability and passivity are judged."""

    critical_stiffness: float | None
    """K_cr(B) [N/m]: 0 when no K > 0 is stable, ∞ when every K > 0 is (None only from a rung that cannot say)."""
    crossover_frequency: float | None
    """ω [rad/s] of the crossover that sets K_cr."""
    crossovers: tuple[Crossover, ...]
    error_estimate: float
    """relative error bound or estimate of critical_stiffness (∞: the rung cannot vouch for it)."""
    error_source: str
    reason: str | None = None
    max_stable_damping: float | None = None
    """B_max [N·s/m] when the rung found it on the way."""


def _linear_rung(device: Device, damping: float, lin: float) -> RungAnswer:
    """Chapter eq. 10: K_cr ≈ (b + B)/(T/2 + t_d) at ω = sqrt(K/m)."""
    w = math.sqrt(lin / device.mass) if lin > 0 else None
    return RungAnswer(lin, w, (Crossover(frequency=w, stiffness=lin),) if w else (),
                      linear_error_estimate(device, damping),
                      "first- and second-order terms in (1+d)(δ+β) dropped by the linearisation (eq. 9/10), fitted on "
                      "the test suite")


def _grid_rung(device: Device, damping: float, grid_points: int) -> RungAnswer:
    """A fixed log grid of ω, crossings interpolated (grid_critical_stiffness)."""
    if not (10 <= grid_points <= MAX_GRID_POINTS):
        raise InputError("grid_points", f"must be between 10 and {MAX_GRID_POINTS}")
    if device.damping + damping <= 0.0:
        # the crossover sits at θ → 0⁺ with K → 0, below any grid: the closed-form limit, not the grid, answers
        return RungAnswer(0.0, None, (), 0.0, "closed form (δ = β = 0): the crossover is at ω → 0 with K → 0",
                          NO_DAMPING_REASON)
    kcr, w, crossovers, err = grid_critical_stiffness(device, damping, grid_points)
    return RungAnswer(kcr, w, crossovers, err, (
        f"the whole change of K across the bracketing grid interval ({grid_points} log-spaced ω from 1e-3/T "
        "to π/T); null (unbounded) when the grid's samples show missed crossovers: Im H > 0 at its lowest "
        "ω, or arg H turning > π/2 between samples where Re H is below the answer, or a crossover with a lower K "
        "under its lowest ω (H sampled there on a refined log grid), or (from the device) a "
        "cable resonance/anti-resonance below the grid or narrower than its spacing, or the delay winding "
        "the phase by π below it"))


def _exact_rung(device: Device, damping: float) -> RungAnswer:
    """Every crossover bracketed and refined (optim.stability.margins)."""
    res = critical_stiffness(device, damping)
    source = ("cable fast path: the binding crossover by bracketed Newton on pieces where closed-form bounds prove "
              "the phase monotone, every other piece proven to hold no lower crossover (the list: every crossover "
              "of the scan)" if res.path == "fast" and device.cable is not None else
              "rigid fast path: the binding crossover by bracketed Newton from closed-form bounds (every other "
              "crossover proven above it; the list past the rising phase proven clear by monotone bounds, else "
              "scanned)" if res.path == "fast" else
              "cable bounded scan (the cable fast path's bounds did not close here): every crossover bracketed on "
              "the scan's grid, those a bound on |H| cannot exclude refined to 4 ulp in ω (the list: every "
              "crossover refined)" if res.path == "bounded-scan" else
              "every crossover bracketed and refined to 4 ulp in ω") + \
        "; agrees with the 40-digit reference to 1e-12 on the test suite"
    if res.unconfirmed is not None:
        # a near-lossless cable whose answer the closed loop can neither confirm nor contradict: no bound is claimed
        return RungAnswer(res.critical_stiffness, res.crossover_frequency, tuple(res.crossovers), math.inf,
                          source + f"; NOT confirmed by the closed loop ({res.unconfirmed}): the cable mode lies within "
                          "1e-12 of the unit circle, where double precision cannot vouch for it (method 'reference' "
                          "can)", res.reason, res.max_stable_damping)
    return _near_b_max(device, damping, res, source)


def _near_b_max(device: Device, damping: float, res, source: str) -> RungAnswer:
    """The exact answer's error estimate with the cancellation near B_max and the inputs' conditioning
    (optim.stability.near_b_max); a cable's binding crossover re-solved in 40 digits where its double evaluation
    cannot certify 1e-12."""
    kcr, w, crossovers = res.critical_stiffness, res.crossover_frequency, tuple(res.crossovers)
    b_max = res.max_stable_damping
    if not (damping > 0.0 and w is not None and math.isfinite(kcr) and kcr > 0.0):
        return RungAnswer(kcr, w, crossovers, EXACT_REL_ERROR, source, res.reason, b_max)
    sens = B_MAX_SENSITIVITY
    if b_max is not None and math.isfinite(b_max) and b_max - damping <= MEASURE_WITHIN * b_max:
        sens = b_max_sensitivity(device, b_max)
    cond = input_conditioning(damping, b_max, sens)
    err = max(EXACT_REL_ERROR, cond)
    if device.cable is None:
        t, scale = device.sample_time, device.stiffness_scale
        rho = cancellation_ratio(loop_plant(device), damping / device.damping_scale, w * t, kcr / scale)
        err = max(err, 8.0 * ROUNDING * rho)      # the closed form is good to a few ulp
        if err > EXACT_REL_ERROR:
            source += (f"; near B_max: K_cr is a difference of terms {rho:.3g}× larger (their rounding) and the inputs' "
                       f"rounding moves it by {cond:.2g} relative (B_max − B is {(b_max - damping) / b_max:.2g} of "
                       "B_max): the estimate carries both")
        return RungAnswer(kcr, w, crossovers, err, source, res.reason, b_max)
    if res.refined_near_b_max is not None:
        source += (f"; near B_max (K_cr a difference of terms {res.refined_near_b_max:.3g}× larger, beyond the double "
                   "evaluation of the cable's 1/G) the binding crossover is re-solved in 40-digit arithmetic on the "
                   "reference rung's discretisation"
                   + (f"; the inputs' rounding moves it by {cond:.2g} relative" if cond > EXACT_REL_ERROR else ""))
    elif cond > EXACT_REL_ERROR:
        source += f"; near B_max the inputs' rounding moves K_cr by {cond:.2g} relative: the estimate carries it"
    return RungAnswer(kcr, w, crossovers, err, source, res.reason, b_max)


def _reference_rung(device: Device, damping: float) -> RungAnswer:
    """40-digit mpmath discretisation and bisection (optim.stability.reference)."""
    res = reference_critical_stiffness(device, damping)
    return RungAnswer(res.critical_stiffness, res.crossover_frequency,
                      tuple(Crossover(frequency=a, stiffness=b) for a, b in res.crossovers),
                      10.0 ** (-(res.digits - 5)), f"{res.digits}-digit mpmath discretisation and bisection", res.reason)


@dataclass(frozen=True)
class WallJudgement:
    """The wall (K, B) against the rung's K_cr: margin, stability and passivity (all None without a stiffness)."""

    gain_margin_db: float | None = None
    stable: bool | None = None
    passive: bool | None = None
    passivity_required_damping: float | None = None
    """max over θ of the delayed Colgate–Schenkel bound [N·s/m]."""
    passivity_conservative: bool = False


#: a stiffness within this relative distance of a band edge past B_max is on it: neither side is claimed
BAND_EDGE_RTOL = 1e-9


def _judge_wall(device: Device, stiffness: float | None, damping: float, kcr: float | None,
                band: StableBand | None = None, estimate: float | None = None,
                rendering: Rendering | None = None) -> WallJudgement:
    """The wall against the rung's K_cr.  ``band``: the stable set past B_max (K_cr = 0); ``estimate``: an approximate
    rung's relative error estimate of K_cr (linear, grid), whose stable label is its own only where K lies outside
    K_cr·(1 ± estimate) (issue 34: past B_max the grid's unbounded K_cr labelled unstable walls stable); None for the
    exact rungs.  ``rendering``: a rendered wall's filter and virtual mass (its own passivity condition)."""
    if stiffness is None:
        return WallJudgement()
    stable: bool | None = bool(kcr is not None and stiffness < kcr)
    gm = gain_margin_db(kcr, stiffness) if kcr and math.isfinite(kcr) else None
    if kcr == 0:
        gm, stable = None, False
        if band is not None and band.status == "undetermined":
            stable = None
        elif band is not None and band.band is not None:
            lo, hi = band.band
            near = any(abs(stiffness / e - 1.0) <= BAND_EDGE_RTOL for e in (lo, hi) if math.isfinite(e))
            stable = None if near else lo < stiffness < hi
    if estimate is not None and stable is not None and not _label_within_estimate(stiffness, kcr, estimate):
        stable = None
    pm = (passivity_margin(device, stiffness, damping) if rendering is None else
          rendered_passivity(device, stiffness, damping, rendering))
    return WallJudgement(gm, stable, pm.passive, pm.required_damping, pm.conservative)


def _label_within_estimate(stiffness: float | None, kcr: float | None, rel_error: float | None) -> bool:
    """Whether K is on one side of K_cr·(1 ± rel_error): an approximate rung's stable label is then its own."""
    if stiffness is None or kcr is None or rel_error is None or not math.isfinite(rel_error):
        return False
    if kcr == 0.0:
        return rel_error == 0.0          # the closed-form limit (no damping at all), exact
    if math.isinf(kcr):
        return False                     # "every K is stable" from a grid: no bound can say so
    return abs(stiffness / kcr - 1.0) > rel_error


@dataclass(frozen=True)
class CableJudgement:
    """For a cable device: Q (eq. 22) and whether its mode moves K_cr against the rigid model's."""

    q_criterion: float | None = None
    """Q ≈ m_r z_n ω_n [N/m]."""
    mode_matters: bool | None = None
    rigid_critical_stiffness: float | None = None
    """the rigid model's K_cr(B) [N/m] (exact and reference rungs)."""


def _judge_cable(device: Device, damping: float, method: str, kcr: float | None) -> CableJudgement:
    if device.cable is None:
        return CableJudgement()
    mode = rigid_k = None
    if method in ("exact", "reference"):
        rigid_k = critical_stiffness(device.rigid(), damping).critical_stiffness
        if kcr is not None and math.isfinite(kcr) and rigid_k and math.isfinite(rigid_k):
            mode = abs(kcr / rigid_k - 1) > MODE_MATTERS_RTOL
    return CableJudgement(Q_criterion(device), mode, rigid_k)


def check_rung(method: str, grid_points: int = DEFAULT_GRID_POINTS) -> Method:
    """InputError naming ``method`` or ``grid_points`` when outside the ladder: the HTTP request's rule and message
    (its fields are Method and GridPoints), for callers that did not come through it.  Returns ``method``, checked
    to be one of the ladder's rungs."""
    if method in METHODS and type(grid_points) is int and MIN_GRID_POINTS <= grid_points <= MAX_GRID_POINTS:
        return cast(Method, method)   # the rules' own verdict, without their validators (≈ 3 µs of a 40 µs analysis)
    for name, rule in _RUNG_RULES:
        try:
            rule.validate_python(method if name == "method" else grid_points)
        except ValidationError as exc:
            raise from_validation(exc, prefix=name) from None
    return cast(Method, method)


def _analyse(device: Device, stiffness: float | None, damping: float, method: str,
             grid_points: int) -> StabilityAnalysis:
    rung_method = check_rung(method, grid_points)
    if stiffness is not None and not (math.isfinite(stiffness) and stiffness > 0):
        raise InputError("stiffness", "must be finite and > 0")
    if not (math.isfinite(damping) and damping >= 0):
        raise InputError("damping", "must be finite and ≥ 0")
    # α and β in the numeric domain (a subnormal B left beta_max None: a TypeError, issue 28)
    if stiffness is not None:
        check_controller_domain(stiffness, device, "stiffness", "stiffness")
    if damping != 0.0:
        check_controller_domain(damping, device, "damping", "damping")
    t0 = time.perf_counter()
    lin = linear_estimate(device, damping)
    if method == "linear":
        rung = _linear_rung(device, damping, lin)
    elif method == "grid":
        rung = _grid_rung(device, damping, grid_points)
    elif method == "exact":
        rung = _exact_rung(device, damping)
    else:
        rung = _reference_rung(device, damping)
    kcr, reason, b_max = rung.critical_stiffness, rung.reason, rung.max_stable_damping
    band = None
    if kcr == 0 and damping > 0 and method in ("exact", "reference"):
        # K_cr = 0 past B_max: the closed loop decides whether some K > 0 is stable all the same
        band = stable_band(device, damping)
        reason = _band_reason(reason, band)
    wall = _judge_wall(device, stiffness, damping, kcr, band,
                       rung.error_estimate if method in ("linear", "grid") else None)
    cable = _judge_cable(device, damping, method, kcr)
    if damping > 0 and b_max is None and method == "exact":
        b_max = max_stable_damping(device)
    lin_err = abs(lin / kcr - 1) if kcr and math.isfinite(kcr) else None
    if kcr is not None and math.isinf(kcr) and reason is None:
        reason = "no phase crossover: every positive stiffness is stable"
    return StabilityAnalysis(
        critical_stiffness=_finite(kcr), crossover_frequency=rung.crossover_frequency, crossovers=rung.crossovers,
        damping=damping, stiffness=stiffness, gain_margin_db=wall.gain_margin_db, stable=wall.stable,
        passive=wall.passive, passivity_required_damping=wall.passivity_required_damping,
        passivity_conservative=wall.passivity_conservative, linear_estimate=lin, linear_error=lin_err,
        max_stable_damping=_finite(b_max), q_criterion=cable.q_criterion, mode_matters=cable.mode_matters,
        rigid_critical_stiffness=_finite(cable.rigid_critical_stiffness), method=rung_method,
        elapsed_ms=(time.perf_counter() - t0) * 1e3, error_estimate=rung.error_estimate,
        error_source=rung.error_source, reason=reason,
        stable_band=band.band if band is not None and band.status == "band" else None)


def _band_reason(reason: str | None, band: StableBand) -> str:
    """The rung's reason for K_cr = 0, with what the closed loop says of the stable set past B_max."""
    base = reason or "no positive stiffness is stable"
    if band.status == "none":
        return f"{base} (the closed loop confirms it: {band.reason})"
    cut = base.replace(": no positive stiffness is stable", "").replace("no positive stiffness is stable", "")
    if band.status == "band":
        return f"{cut.rstrip(': ;')}: K_cr = 0 (unstable as K → 0⁺), but {band.reason}"
    return f"{cut.rstrip(': ;')}: K_cr = 0 (unstable as K → 0⁺); whether a band of larger K is stable is undetermined " \
        f"({band.reason})"


#: why only the exact rung analyses a velocity filter or a virtual mass
RENDERED_RUNGS = ("only the exact rung analyses a velocity filter or a virtual mass: eq. 10 (linear), the grid's "
                  "error bounds and the 40-digit reference are written for C(z) = K + B(1 − z⁻¹)/T")


def _rendered_rung(device: Device, damping: float, rendering: Rendering) -> RungAnswer:
    """Every crossover of h_K = −1/G_n − βV_n − μA_n bracketed and refined (optim.stability.rendered)."""
    res = rendered_critical_stiffness(device, damping, rendering)
    source = ("every crossover of the rendered wall C(z) = K + B·V(z) + M·A(z) bracketed and refined to 4 ulp "
              "in ω (the adaptive scan, the filter's poles and zeros among its clusters); the K → 0⁺ loop "
              "decided by the crossings of B and M along two paths; confirmed by closed-loop eigenvalues "
              "with the filter's states (docs/properties_filter.md)")
    kcr, w, crossovers, err, why = _rendered_estimate(device, damping, rendering, res)
    return RungAnswer(kcr, w, crossovers, err, source + (f"; {why}" if why else ""), res.reason,
                      res.max_stable_damping)


def _rendered_estimate(device: Device, damping: float, rendering: Rendering, res
                       ) -> tuple[float, float | None, tuple[Crossover, ...], float, str | None]:
    """(K_cr, ω, crossovers, error estimate, why) of the rendered rung near B_max (issue 34), as today's wall's
    (``_near_b_max``): K = Re h_K at the crossover is a difference of terms ρ times larger, each evaluated to a few ulp
    (the plant's 1/G_n; the filter's V_n by Horner, whose rounding grows with Σ|coefficients|/|polynomial|), and the
    inputs' rounding moves it by the conditioning near B_max.  A cable whose ρ exceeds RHO_REFINE (its modal 1/G_n is
    not good to a few ulp there) has its binding crossover re-solved in 40 digits with the filter
    (optim.stability.near_b_max.refine_cable_crossover); where that does not settle no bound is claimed."""
    kcr, w, b_max = res.critical_stiffness, res.crossover_frequency, res.max_stable_damping
    crossovers = tuple(res.crossovers)
    if not (damping > 0.0 and w is not None and math.isfinite(kcr) and kcr > 0.0):
        return kcr, w, crossovers, EXACT_REL_ERROR, None
    t = device.sample_time
    theta = np.array([w * t])
    alpha, beta, mu = kcr / device.stiffness_scale, damping / device.damping_scale, rendering.mass / device.mass
    vel = rendering.velocity
    inv = abs(complex(loop_plant(device).inverse_response(theta)[0]))
    v = abs(complex(vel.response(theta)[0]))
    zinv = complex(np.exp(-1j * theta[0]))
    r_at = abs(sum(c * zinv ** k for k, c in enumerate(vel.r)))
    d_at = abs(sum(c * zinv ** k for k, c in enumerate(vel.d)))
    horner = 2.0 * (len(vel.r) * sum(map(abs, vel.r)) / max(r_at, 1e-300)
                    + len(vel.d) * sum(map(abs, vel.d)) / max(d_at, 1e-300))
    terms = beta * v + abs(mu) * v * abs(complex(np.expm1(-1j * theta[0])))
    rho = (inv + terms) / alpha
    rounding = ROUNDING * (8.0 * inv + (8.0 + horner) * terms) / alpha
    cond = input_conditioning(damping, b_max, B_MAX_SENSITIVITY + len(vel.r) + len(vel.d))
    err = max(EXACT_REL_ERROR, rounding, cond)
    if device.cable is not None and rho > RHO_REFINE:
        got = None
        if device.delay_samples <= REFERENCE_STIFFNESS_MAX_DELAY_SAMPLES:
            got = refine_cable_crossover(device, damping, w * t, velocity=(vel.r, vel.d), mu=mu)
        if got is None or not got[1] > 0.0:
            return kcr, w, crossovers, math.inf, (
                f"near B_max K_cr is a difference of terms {rho:.3g}× larger, beyond the double evaluation of the "
                "cable's 1/G_n, and its 40-digit re-solve did not settle (or gave K ≤ 0, or the delay is past the "
                "reference rung's cap): no error bound is claimed")
        new_k, new_w = got[1] * device.stiffness_scale, got[0] / t
        crossovers = tuple(Crossover(new_w, new_k) if c.frequency == w and c.stiffness == kcr else c
                           for c in crossovers)
        if new_k > min(c.stiffness for c in crossovers):
            return kcr, w, tuple(res.crossovers), math.inf, (
                "near B_max the binding crossover re-solved in 40 digits is no longer the least: no error bound is "
                "claimed")
        return new_k, new_w, crossovers, max(EXACT_REL_ERROR, cond), (
            f"near B_max (K_cr a difference of terms {rho:.3g}× larger, beyond the double evaluation of the cable's "
            "1/G_n) the binding crossover is re-solved in 40-digit arithmetic with the filter and the virtual mass "
            "(the reference rung's discretisation)"
            + (f"; the inputs' rounding moves it by {cond:.2g} relative" if cond > EXACT_REL_ERROR else ""))
    if err > EXACT_REL_ERROR:
        return kcr, w, crossovers, err, (
            f"near B_max: K_cr is a difference of terms {rho:.3g}× larger (their rounding, the filter's evaluation "
            f"included) and the inputs' rounding moves it by {cond:.2g} relative: the estimate carries both")
    return kcr, w, crossovers, err, None


def _analyse_rendered(device: Device, stiffness: float | None, damping: float, method: str, grid_points: int,
                      rendering: Rendering) -> StabilityAnalysis:
    rung_method = check_rung(method, grid_points)
    if stiffness is not None and not (math.isfinite(stiffness) and stiffness > 0):
        raise InputError("stiffness", "must be finite and > 0")
    if not (math.isfinite(damping) and damping >= 0):
        raise InputError("damping", "must be finite and ≥ 0")
    if rendering.is_default:
        plain = _analyse(device, stiffness, damping, method, grid_points)
        if stiffness is None or method != "exact":
            return plain
        t0 = time.perf_counter()
        mass = rendered_mass_range(device, stiffness, damping, rendering)
        return replace(plain, mass_range=mass, elapsed_ms=plain.elapsed_ms + (time.perf_counter() - t0) * 1e3)
    if method != "exact":
        raise InputError("method", RENDERED_RUNGS)
    t0 = time.perf_counter()
    lin = linear_estimate(device, damping)
    rung = _rendered_rung(device, damping, rendering)
    kcr, reason, b_max = rung.critical_stiffness, rung.reason, rung.max_stable_damping
    band = None
    if kcr == 0 and device.damping + damping > 0:
        # "no positive stiffness is stable" is the rung's K → 0⁺ walk: the closed loop with the filter's states and
        # the virtual mass decides whether some K > 0 is stable all the same, as for today's wall
        band = stable_band(device, damping, rendering)
        reason = _band_reason(reason, band)
    wall = _judge_wall(device, stiffness, damping, kcr, band, rendering=rendering)
    mass = None
    if stiffness is not None and wall.stable and kcr:
        mass = rendered_mass_range(device, stiffness, damping, rendering)
    cable = CableJudgement()
    if device.cable is not None:
        rigid_k = rendered_critical_stiffness(device.rigid(), damping, rendering).critical_stiffness
        mode = None
        if kcr is not None and math.isfinite(kcr) and rigid_k and math.isfinite(rigid_k):
            mode = abs(kcr / rigid_k - 1) > MODE_MATTERS_RTOL
        cable = CableJudgement(Q_criterion(device), mode, rigid_k)
    lin_err = abs(lin / kcr - 1) if kcr and math.isfinite(kcr) else None
    return StabilityAnalysis(
        critical_stiffness=_finite(kcr), crossover_frequency=rung.crossover_frequency, crossovers=rung.crossovers,
        damping=damping, stiffness=stiffness, gain_margin_db=wall.gain_margin_db, stable=wall.stable,
        passive=wall.passive, passivity_required_damping=wall.passivity_required_damping,
        passivity_conservative=wall.passivity_conservative, linear_estimate=lin,
        linear_error=lin_err, max_stable_damping=_finite(b_max), q_criterion=cable.q_criterion,
        mode_matters=cable.mode_matters, rigid_critical_stiffness=_finite(cable.rigid_critical_stiffness),
        method=rung_method, elapsed_ms=(time.perf_counter() - t0) * 1e3, error_estimate=rung.error_estimate,
        error_source=rung.error_source, reason=reason, mass_range=mass,
        stable_band=band.band if band is not None and band.status == "band" else None)
