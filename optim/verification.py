"""``verify: true``: an independent proof of a critical gain, a design's margin and its passivity.

The check shares no code with the crossover scan (optim.stability.crossovers, optim.stability.margins, models.discretize):
it closes the loop in optim.stability.closed_loop, built again from the device's physical parameters, and asks
whether the loop is stable just below the answer and unstable just above it:

* ``eigenvalues``: the spectral radius of the closed-loop state matrix (whole-sample delay as a shift
  register, the fractional part through the augmented discretisation), used while the state count is at
  most :data:`EIG_MAX_STATES` and the radius is decided beyond its own rounding bound;
* ``argument principle``: otherwise, the number of closed-loop poles outside the unit circle, from the
  winding of the return difference 1 + C·G around the unit circle (any delay up to the 10,000-sample
  limit; no radius, a count).  A closed-loop pole that double precision places within its own reach of the
  circle (at K_cr·(1 ± 1e-6) the crossing pole may sit 1e-17 off it) is decided in 50-digit mpmath on an arc
  around it (optim.stability.circle_reach, the plant sampled again in mpmath by optim.stability.closed_loop_mp);
  where even that cannot place it, the point is not decided and the verdict is ``not_checkable``.

A contradiction is a verdict, never an exception: the caller returns it as ``contradicted``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import Literal

import mpmath as mp
import numpy as np
from scipy.optimize import minimize_scalar

from models.device import Device
from optim.stability.closed_loop import (
    SampledPlant,
    UnstableCount,
    circle_poles,
    count_outside,
    radius_excess,
    sampled_plant,
    stiffness_closed_loop,
    unstable_count,
)
from optim.stability.closed_loop_mp import PRECISE_DIGITS, mp_return_difference
from optim.stability.closed_loop_rendered import (
    filter_poles,
    filter_polynomials,
    rendered_closed_loop,
    rendered_controller,
    rendered_return_difference,
    rendered_states,
)

__all__ = [
    "check_point",
    "DEFAULT_EPSILON",
    "claimed_epsilon",
    "labelled",
    "not_checkable",
    "EIG_MAX_STATES",
    "PASSIVITY_RTOL",
    "PassivityVerification",
    "Verdict",
    "Verification",
    "verify_analysis",
    "verify_boundary",
    "verify_critical_force_gain",
    "verify_critical_stiffness",
    "verify_force_feedforward",
    "verify_passivity",
    "verify_rendered_passivity",
    "RENDERED_PASSIVITY_RTOL",
    "verify_stiffness_design",
    "whole_delay_samples",
]

Verdict = Literal["confirmed", "contradicted", "not_checkable"]

_EPS = 2.220446049250313e-16

#: relative step around an exact (or reference) answer: far above its claimed 1e-12, far below any use
DEFAULT_EPSILON = 1e-6
#: closed-loop states up to which the dense eigenvalue method is tried (cost ~ n³; ≈ 5 ms at 160)
EIG_MAX_STATES = 160

EIGEN = "eigenvalues of the closed-loop state matrix (optim.stability.closed_loop)"
ARGUMENT = "argument principle: winding of 1 + C·G on the unit circle (optim.stability.closed_loop)"


@dataclass(frozen=True)
class PassivityVerification:
    """The delayed Colgate–Schenkel condition evaluated again from its frequency-domain form."""

    verdict: Verdict
    required_damping: float | None
    """the largest value met of (T/2)·Re[(1 − e^{−jθ})·e^{−jdθ}·C(e^{jθ})]/(1 − cos θ) [N·s/m] (the verdict rests
    on verify's own proof, :func:`_certify`, not on this number)."""
    physical_damping: float
    """b [N·s/m]."""
    reason: str | None
    label: Literal["passive", "not passive"] = "passive"
    """the label checked (the answer's ``passive``)."""
    label_confirmed: Literal["passive", "not passive"] | None = None
    """the label this record confirms: ``label`` when the verdict is confirmed, else None."""


@dataclass(frozen=True)
class Verification:
    """The closed loop just below and just above a critical gain, by a method independent of the answer."""

    verdict: Verdict
    method: str | None
    epsilon: float | None
    """the relative step: the loop is checked at gain·(1 − ε) and gain·(1 + ε)."""
    gain_below: float | None
    """the gain checked below (K [N/m] or K_f)."""
    gain_above: float | None
    radius_below: float | None
    """spectral radius of the closed loop at gain_below (eigenvalue method; null for the argument principle)."""
    radius_above: float | None
    unstable_poles_below: int | None
    """closed-loop poles outside the unit circle at gain_below (argument principle; null for eigenvalues)."""
    unstable_poles_above: int | None
    elapsed_ms: float
    reason: str | None
    design_radius: float | None = None
    """designs: spectral radius at the designed gain itself (must be < 1)."""
    design_unstable_poles: int | None = None
    passivity: PassivityVerification | None = None
    points: tuple | None = None
    """robust designs: one optim.verification_robust.PointVerification per checked device of the box."""
    label: str | None = None
    """what the record checks, in the answer's words: the critical gain, and the wall's own labels (``stable``,
    ``passive`` / ``not passive``) when the answer gives them."""
    label_confirmed: str | None = None
    """``label`` when the verdict is confirmed (every part of it holds), else None: what was confirmed, explicitly."""


def labelled(v: Verification, label: str | None) -> Verification:
    """The record with its ``label``, and ``label_confirmed`` = the label when the verdict is confirmed."""
    return replace(v, label=label, label_confirmed=label if v.verdict == "confirmed" and label else None)


def _gain_label(name: str, critical: float | None, unit: str) -> str:
    if critical is None or math.isinf(critical):
        return f"every {name.split('_', 1)[1].replace('_', ' ')} is stable"
    if critical == 0.0:
        return f"{name} = 0: no positive {name.split('_', 1)[1].replace('_', ' ')} is stable"
    return f"{name} = {critical:.9g}{unit}"


@dataclass(frozen=True)
class _Point:
    stable: bool | None           # None: not decided
    radius: float | None
    count: int | None
    method: str | None
    reason: str | None


def _check_point(device: Device, plant: SampledPlant, alpha: float, beta: float, render: tuple | None = None) -> _Point:
    if render is not None:
        return _rendered_point(device, plant, alpha, beta, render)
    n = plant.e.shape[0] + 1 + plant.d + (1 if plant.f > 0 else 0)
    if n <= EIG_MAX_STATES:
        ex = radius_excess(stiffness_closed_loop(plant, alpha, beta))
        if ex.decided_stable or ex.decided_unstable:
            return _Point(ex.decided_stable, 1.0 + ex.excess, None, EIGEN, None)
    cnt = unstable_count(device, plant, alpha, beta, mp_return_difference(device, alpha, beta, PRECISE_DIGITS),
                         PRECISE_DIGITS)
    return _counted(cnt)


def _counted(cnt: UnstableCount) -> _Point:
    """The argument principle's verdict; the poles it decided in mpmath (below double precision's reach) named in
    the method."""
    method = f"{ARGUMENT}; {cnt.precise}" if cnt.precise else ARGUMENT
    if cnt.count is None:
        return _Point(None, None, None, method, cnt.reason)
    return _Point(cnt.count == 0, None, cnt.count, method, None)


#: the closed loop's verdict at one (α, β): eigenvalues with their rounding bound up to EIG_MAX_STATES states, else
#: the argument principle (optim.stability.stable_band and optim.scene_verdict decide past B_max with it)
check_point = _check_point


def _rendered_point(device: Device, plant: SampledPlant, alpha: float, beta: float, render: tuple) -> _Point:
    """The closed loop with the velocity filter's states and the virtual mass (``render`` = (filter spec, M [kg]))."""
    spec, mass = render
    t, mu = device.sample_time, mass / device.mass
    if rendered_states(plant, spec, t) <= EIG_MAX_STATES:
        ex = radius_excess(rendered_closed_loop(plant, spec, t, alpha, beta, mu))
        if ex.decided_stable or ex.decided_unstable:
            return _Point(ex.decided_stable, 1.0 + ex.excess, None, EIGEN, None)
    m1, pairs = circle_poles(device)
    poles = np.concatenate([1.0 + np.linalg.eigvals(plant.e), filter_poles(spec, t)])
    num, den = rendered_controller(spec, t, alpha, beta, mu)
    precise = mp_return_difference(device, alpha, beta, PRECISE_DIGITS, (tuple(num), tuple(den)))
    cnt = count_outside(lambda th: rendered_return_difference(plant, spec, t, alpha, beta, mu, th), poles, plant.d,
                        m1, pairs, precise, PRECISE_DIGITS)
    return _counted(cnt)


def claimed_epsilon(method: str, error_estimate: float | None, linear_factor: float = 1.0) -> float | None:
    """The relative step ε at which an answer of rung ``method`` is checked: its own claim.

    :data:`DEFAULT_EPSILON` for ``exact`` and ``reference`` (they claim 1e-12 and better; their estimate where it is
    wider, near B_max); the rung's error estimate
    for ``grid``, times ``linear_factor`` for ``linear`` (the stiffness rung documents its estimate as within 2× of
    the true error), never below DEFAULT_EPSILON; None when the estimate is unbounded (the rung claims no bound)."""
    if method in ("exact", "reference"):
        # their claim is 1e-12 and better, except near B_max, where the estimate carries the conditioning (issue 34):
        # checked at that estimate where it is wider than the step
        if error_estimate is not None and math.isfinite(error_estimate):
            return max(DEFAULT_EPSILON, float(error_estimate))
        return DEFAULT_EPSILON
    if error_estimate is None or not math.isfinite(error_estimate):
        return None
    return max(float(error_estimate) * (linear_factor if method == "linear" else 1.0), DEFAULT_EPSILON)


def not_checkable(t0: float, reason: str, eps: float | None = None, **kw) -> Verification:
    """A ``not_checkable`` record with its reason, timed from ``t0`` (perf_counter); ``kw``: method, gain_below,
    gain_above and any other Verification field."""
    return Verification("not_checkable", kw.pop("method", None), eps, kw.pop("gain_below", None),
                        kw.pop("gain_above", None), None, None, None, None, (time.perf_counter() - t0) * 1e3, reason, **kw)


def _methods(*points: _Point) -> str:
    used = []
    for p in points:
        if p.method and p.method not in used:
            used.append(p.method)
    return "; ".join(used)


def verify_critical_stiffness(device: Device, damping: float, critical: float | None,
                              epsilon: float = DEFAULT_EPSILON, next_crossing: float | None = None,
                              render: tuple | None = None) -> Verification:
    """:func:`_critical_stiffness_check`, labelled with the critical stiffness it checks."""
    return labelled(_critical_stiffness_check(device, damping, critical, epsilon, next_crossing, render),
                    _gain_label("critical_stiffness", critical, " N/m"))


def _critical_stiffness_check(device: Device, damping: float, critical: float | None,
                              epsilon: float = DEFAULT_EPSILON, next_crossing: float | None = None,
                              render: tuple | None = None) -> Verification:
    """Is the loop with this B stable at K_cr·(1 − ε) and unstable at K_cr·(1 + ε)?

    ``critical``: the answer to check [N/m]; 0 (no positive K stable) is checked as instability at a small
    K; None or inf (every K stable) is not checkable at finitely many gains, but a K that is unstable
    contradicts it.  ``next_crossing``: the next larger crossover's K, when the answer lists one: ε is
    kept below half the gap, so that the point above stays below it.  ``epsilon`` ≥ 0.5 (an approximate
    rung's own error estimate) checks K/(1 + ε) below instead of a non-positive K.  ``render``: (velocity filter
    spec, virtual mass M [kg]) of a rendered wall, closed with the filter's states
    (optim.stability.closed_loop_rendered); None: today's wall.
    """
    t0 = time.perf_counter()
    m, t = device.mass, device.sample_time
    to_alpha, beta = t * t / m, damping * t / m
    plant = sampled_plant(device)
    if critical is not None and critical == 0.0:
        # no positive K is stable: the loop must be unstable already at a small K
        k_small = min(1e-6 * (device.damping + damping) / (t / 2 + device.delay), 1e-9 / to_alpha) or 1e-9 / to_alpha
        p = _check_point(device, plant, k_small * to_alpha, beta, render)
        verdict: Verdict = "confirmed" if p.stable is False else ("contradicted" if p.stable else "not_checkable")
        reason = ("K_cr = 0: the loop is unstable at a small K" if p.stable is False else
                  "K_cr = 0 but the loop is stable at a small K" if p.stable else p.reason)
        return Verification(verdict, p.method, None, None, k_small, None, p.radius, None, p.count,
                            (time.perf_counter() - t0) * 1e3, reason)
    if critical is None or math.isinf(critical):
        probe = 100.0 * (device.damping + damping) / (t / 2 + device.delay) or 1.0 / to_alpha
        p = _check_point(device, plant, probe * to_alpha, beta, render)
        if p.stable is False:
            return Verification("contradicted", p.method, None, None, probe, None, p.radius, None, p.count,
                                (time.perf_counter() - t0) * 1e3, "every K was said stable, but this K is not")
        return not_checkable(t0, "no finite set of gains proves that every K > 0 is stable", method=p.method,
                              gain_above=probe)
    if not (math.isfinite(critical) and critical > 0 and math.isfinite(epsilon) and epsilon > 0):
        return not_checkable(t0, "no finite positive answer or step to check")
    cap = math.inf
    if next_crossing is not None and math.isfinite(next_crossing) and next_crossing > critical:
        cap = 0.5 * (next_crossing / critical - 1.0)
    eps = min(epsilon, cap)
    # an exact answer whose ±1e-6 is below double precision's reach (tiny δ on the eigenvalue path) gets a
    # second, larger step: still far inside any use, still below the next crossover
    wider = min(1e-3, cap)
    tries = [eps, wider] if epsilon == DEFAULT_EPSILON and wider > eps else [eps]
    last: Verification | None = None
    for e in tries:
        k_lo = critical * (1.0 - e) if e < 0.5 else critical / (1.0 + e)
        k_hi = critical * (1.0 + e)
        lo = _check_point(device, plant, k_lo * to_alpha, beta, render)
        hi = _check_point(device, plant, k_hi * to_alpha, beta, render)
        out = Verification("not_checkable", _methods(lo, hi), e, k_lo, k_hi, lo.radius, hi.radius, lo.count,
                           hi.count, 0.0, None)
        if lo.stable is False or hi.stable is True:
            what = []
            if lo.stable is False:
                what.append(f"unstable at K = {k_lo:.9g} below the answer")
            if hi.stable is True:
                what.append(f"stable at K = {k_hi:.9g} above the answer")
            return replace(out, verdict="contradicted", reason="; ".join(what),
                           elapsed_ms=(time.perf_counter() - t0) * 1e3)
        if lo.stable is True and hi.stable is False:
            return replace(out, verdict="confirmed", elapsed_ms=(time.perf_counter() - t0) * 1e3)
        last = replace(out, reason=lo.reason or hi.reason or "not decided")
    assert last is not None    # tries is never empty
    return replace(last, elapsed_ms=(time.perf_counter() - t0) * 1e3)


# --- passivity: the Colgate–Schenkel condition written as a frequency response -----------------------------

#: relative rounding allowance of the recomputed condition in floats (:func:`_required_terms`), used by the float
#: screen of :func:`_certify`: this times the value's rounding scale (the sum of the moduli of the products it is
#: made of, the delay's phase error d·θ·u included) bounds its error.
#: Each product and sum rounds once, so the error is ≤ ≈ 16·u·scale = 1.8e-15·scale (u = 1.1e-16); measured
#: against 40-digit mpmath up to the 10,000-sample limit it is ≤ 3.4e-16·scale
#: (tests/optim/test_verification_passivity.py).  1e-12 is that bound ×500, and the design back-off
#: (optim.stiffness.requirements.DESIGN_BACK_OFF = 1e-8 of K, ≥ 1e-9 of b in practice) is 1,000× larger still,
#: so that every design sitting on its passivity constraint is decided.
PASSIVITY_RTOL = 1e-12


def _required_terms(device: Device, stiffness: float, damping: float, whole: int,
                    theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(T/2)·Re[(1 − e^{−jθ})·e^{−jdθ}·C(e^{jθ})]/(1 − cos θ) for θ ∈ (0, π], and its rounding scale.

    Written out in real arithmetic so that the scale is the sum of the moduli of exactly the products that are
    rounded: a = 1 − e^{−jθ} (expm1: accurate at small θ), e = e^{−jφ} with φ = dθ (absolute error ≤ φ·u),
    z = a·e, and C = K + B·a/T, so the value is (T/2)·K·Re z/(1 − cos θ) + (B/2)·Re(z·a)/(1 − cos θ)."""
    t = device.sample_time
    am = -np.expm1(-1j * theta)
    ar, ai = am.real, am.imag
    phi = whole * theta
    er, ei = np.cos(phi), -np.sin(phi)
    amod = np.abs(am)
    zr, zi = ar * er - ai * ei, ar * ei + ai * er
    szr = np.abs(ar * er) + np.abs(ai * ei) + amod * phi
    szi = np.abs(ar * ei) + np.abs(ai * er) + amod * phi
    den = 2.0 * np.sin(theta / 2) ** 2
    k_part = (t / 2) * stiffness * zr / den
    b_part = 0.5 * damping * (zr * ar - zi * ai) / den
    scale = ((t / 2) * abs(stiffness) * szr + 0.5 * abs(damping) * (szr * np.abs(ar) + szi * np.abs(ai))) / den
    return k_part + b_part, scale


def _required_samples(device: Device, stiffness: float, damping: float,
                      whole: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """verify's own grid (geometric from 1e-7 to 1e-2, then ≥ 64 points per period of the delay's phase up to π),
    the condition there and its rounding scales."""
    n = max(4096, 64 * (whole + 1))
    grid = np.concatenate([np.geomspace(1e-7, 1e-2, 200), np.linspace(1e-2, math.pi, n)[1:]])
    vals, scales = _required_terms(device, stiffness, damping, whole, grid)
    return grid, vals, scales


def _required_damping(device: Device, stiffness: float, damping: float, whole: int, grid: np.ndarray | None = None,
                      vals: np.ndarray | None = None) -> tuple[float, float, float]:
    """sup over θ ∈ (0, π] of (T/2)·Re[(1 − e^{−jθ})·e^{−jdθ}·C(e^{jθ})]/(1 − cos θ), its θ, and its rounding
    scale there (see :data:`PASSIVITY_RTOL`).

    The same theorem as optim.stability.passivity but evaluated from the complex form (no Dirichlet kernel):
    a dense grid (≥ 64 points per period of the delay's phase), a bounded refinement of its 6 highest local
    maxima (not of 3 neighbouring points of one peak, which could hide a second peak a little higher), and the
    limit θ → 0⁺ from the series of the complex form: (1 − e^{−jθ})·e^{−jdθ} = jθ + (d + ½)θ² + O(θ³) and
    C = K + B·jθ/T + O(θ²) give K·T·(d + ½) − B (reported at θ = 0).
    """
    def f(theta: float) -> float:
        return float(_required_terms(device, stiffness, damping, whole, np.array([theta]))[0][0])

    if grid is None or vals is None:
        grid, vals, _ = _required_samples(device, stiffness, damping, whole)
    padded = np.concatenate([[-np.inf], vals, [-np.inf]])
    peaks = np.flatnonzero((vals >= padded[:-2]) & (vals >= padded[2:]))
    best_t, best_v = float(grid[int(np.argmax(vals))]), float(np.max(vals))
    for i in peaks[np.argsort(vals[peaks])[-6:]]:
        a, b = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
        if b > a:
            r = minimize_scalar(lambda x: -f(x), bounds=(a, b), method="bounded",
                                options={"xatol": 1e-13 * max(a, 1e-12)})
            if -r.fun > best_v:
                best_t, best_v = float(r.x), float(-r.fun)
    k0, b0 = stiffness * device.sample_time * (whole + 0.5), -damping
    if k0 + b0 >= best_v:
        return k0 + b0, 0.0, abs(k0) + abs(b0)
    _, scale = _required_terms(device, stiffness, damping, whole, np.array([best_t]))
    return best_v, best_t, float(scale[0])


def whole_delay_samples(device: Device) -> int:
    """⌈t_d/T⌉, the whole samples of delay of the delayed Colgate–Schenkel test (ARCHITECTURE.md: a fractional
    delay is rounded up).  A quotient within 64 ulp of a whole number is that number (0.003/0.001 is
    2.9999999999999996 and 3.0000000000000004 comes from the same intent): the rule of models.discretize.split_delay,
    written again here (verify shares no code with the analysis; tests/optim/test_verification_passivity.py holds
    the two equal)."""
    r = device.delay / device.sample_time
    n = round(r)
    if abs(r - n) <= 64 * _EPS * max(1.0, r):
        return int(n)
    return int(math.ceil(r))


def _mp_value(t: float, k: float, b: float, whole: int, theta) -> "mp.mpf":
    """(T/2)·Re[(1 − e^{−jθ})·e^{−jdθ}·C(e^{jθ})]/(1 − cos θ) in mpmath (the caller's precision), with
    1 − e^{−jθ} = 2j·sin(θ/2)·e^{−jθ/2} (no cancellation at small θ); the limit K·T·(d + ½) − B at θ = 0."""
    if theta == 0:
        return mp.mpf(k) * mp.mpf(t) * (whole + mp.mpf(1) / 2) - mp.mpf(b)
    x = mp.mpf(theta)
    s = mp.sin(x / 2)
    a = 2j * s * mp.expjpi(-x / (2 * mp.pi))
    c = mp.mpf(k) + mp.mpf(b) * a / mp.mpf(t)
    z = a * mp.expjpi(-whole * x / mp.pi) * c
    return mp.mpf(t) / 2 * mp.re(z) / (2 * s * s)


#: the resolution of verify's 40-digit decision, relative to the condition's size times d + 1
MP_RTOL = 1e-28
#: mpmath evaluations the proof may spend before it says not_checkable
_PROOF_EVALS = 4000


def _certify(device: Device, k: float, b_virt: float, whole: int, b: float, tol: float,
             grid: np.ndarray, vals: np.ndarray, scales: np.ndarray) -> tuple[bool | None, float, float, str | None]:
    """Decide b > sup P with a proof of its own: (passive, the largest value met, its θ, reason when undecided).

    Not passive: a witness θ at which the condition, evaluated in 40-digit mpmath, reaches b + tol.  Passive: every
    interval of verify's own grid (θ = 0, then the samples above 1e-7) bounded below b − tol, by
      * the modulus: |Re[(1 − e^{−jθ})e^{−jdθ}C]| ≤ 2 sin(θ/2)·|C(e^{jθ})|, so the condition is at most
        T·|C(e^{jθ})|/(2 sin(θ/2)) = √((KT/2)²/sin²(θ/2) + KTB + B²), which falls with θ (the delay drops out);
      * the curvature: its second derivative is at most M2 = (KT/2)·d(d+1)(2d+1)/3 + |B|·(d+1)² (the Dirichlet
        sum's), so on [a, c] it is at most max(f(a), f(c)) + M2·(c − a)²/8;
    in floats with each value's rounding scale (16u of it bounds the error; PASSIVITY_RTOL is taken), and where that does not
    clear an interval, in mpmath by bisection with the curvature bound until it clears or a witness appears.
    Neither within the budget: undecided (b within tol of the sup, as the caller's band says)."""
    t = device.sample_time
    hk, ab = abs(k) * t / 2, abs(b_virt)
    m2 = (hk * whole * (whole + 1.0) * (2 * whole + 1.0) / 3.0 + ab * (whole + 1.0) ** 2) * (1 + 1e-12)
    best_i = int(np.argmax(vals))
    best_v, best_t = float(vals[best_i]), float(grid[best_i])
    th = np.concatenate([[0.0], grid])
    fv = np.concatenate([[k * t * (whole + 0.5) - b_virt], vals])
    sc = np.concatenate([[abs(k * t * (whole + 0.5)) + ab], scales])
    err = PASSIVITY_RTOL * np.maximum(sc[:-1], sc[1:])
    h = np.diff(th)
    with np.errstate(divide="ignore"):
        env = np.sqrt((hk / np.sin(th[:-1] / 2)) ** 2 + abs(k) * t * ab + ab * ab) * (1 + 1e-13)
    ub = np.minimum(np.maximum(fv[:-1], fv[1:]) + err + m2 * h * h / 8, env)
    # the last sample is π's neighbour: the interval up to π itself
    ub_pi = min(float(fv[-1] + err[-1] + m2 * (math.pi - th[-1]) ** 2 / 8), float(env[-1]))
    open_i = np.flatnonzero(ub >= b - tol).tolist()
    with mp.workdps(40):
        evals = 0
        stack = [(mp.mpf(float(th[i])), mp.mpf(float(th[i + 1]))) for i in open_i]
        if ub_pi >= b - tol:
            stack.append((mp.mpf(float(th[-1])), +mp.pi))
        vals_mp: dict = {}
        unresolved = False

        def f(x):
            nonlocal evals
            key = str(x)
            if key not in vals_mp:
                vals_mp[key] = _mp_value(t, k, b_virt, whole, x)
                evals += 1
            return vals_mp[key]

        while stack:
            if evals > _PROOF_EVALS:
                return None, best_v, best_t, (f"the proof did not close within {_PROOF_EVALS} 40-digit evaluations "
                                              "(b is within reach of the sup)")
            a, c = stack.pop()
            fa, fc = f(a), f(c)
            top = fa if fa >= fc else fc
            if float(top) > best_v:
                best_v, best_t = float(top), float(a if fa >= fc else c)
            if top >= b + tol:
                return False, float(top), float(a if fa >= fc else c), None
            if float(top + m2 * (c - a) ** 2 / 8) < b - tol:
                continue
            if float(m2 * (c - a) ** 2 / 8) < tol * 1e-3:
                unresolved = True   # P is within tol of b here (a flank crossing b, or b at the sup): go on
                continue
            mid = (a + c) / 2
            stack += [(a, mid), (mid, c)] if fa >= fc else [(mid, c), (a, mid)]   # the higher end first
    if unresolved:
        return None, best_v, best_t, "b equals the condition to within tol somewhere and no value exceeds it"
    return True, best_v, best_t, None


def verify_passivity(device: Device, stiffness: float, damping: float, claimed: bool) -> PassivityVerification:
    """The claimed passivity of (K, B) against the condition recomputed from its complex form, with a proof of its
    own (:func:`_certify`: a 40-digit witness above b, or every interval of its own grid bounded below b).

    The delay is ⌈t_d/T⌉ (:func:`whole_delay_samples`, the analysis' rule).  Decided beyond :data:`MP_RTOL` (the
    40-digit resolution); otherwise, or when the proof does not close within its budget, not_checkable with the
    reason.  A design backs off by DESIGN_BACK_OFF = 1e-8 of K, far outside."""
    whole = whole_delay_samples(device)
    grid, vals, scales = _required_samples(device, stiffness, damping, whole)
    req, theta, scale = _required_damping(device, stiffness, damping, whole, grid, vals)
    b = device.damping
    # 40-digit values of the condition for these (float) inputs are good to ~1e-36 of the phase's size: a witness
    # or a bound beyond MP_RTOL of it decides
    tol = MP_RTOL * (abs(stiffness) * device.sample_time * (whole + 1) + abs(damping) + abs(b)) * (whole + 1)
    if req >= b + tol:   # the float search's maximum: a 40-digit witness when it holds there
        with mp.workdps(40):
            w = float(_mp_value(device.sample_time, stiffness, damping, whole, theta))
        if w >= b + tol:
            return _passivity_record(False, claimed, max(req, w), b, True)
    passive, best, _, why = _certify(device, stiffness, damping, whole, b, tol, grid, vals, scales)
    req = max(req, best)
    if passive is None:
        return PassivityVerification("not_checkable", req, b, why, _word(claimed), None)
    hk = abs(stiffness) * device.sample_time / 2
    band = (1e-13 + 3e-15 * (whole + 2)) * (hk * (2 * whole + 1) + abs(damping))
    if passive and not claimed:
        # the analysis says 'not passive' on its safe side when b is within its error bound above the sup: a
        # contradiction needs the sup below b − band too
        below, _, _, _ = _certify(device, stiffness, damping, whole, b - band, tol, grid, vals, scales)
        if below is not True:
            return PassivityVerification("not_checkable", req, b,
                                         "passive, but b may exceed the sup by less than the analysis' stated error "
                                         "bound (1e-13 of the scale plus its rounding): 'not passive' is its safe "
                                         "side there", _word(claimed), None)
    return _passivity_record(passive, claimed, req, b, not passive)


def _word(passive: bool) -> Literal["passive", "not passive"]:
    return "passive" if passive else "not passive"


def _passivity_record(passive: bool, claimed: bool, req: float, b: float, witness: bool) -> PassivityVerification:
    if passive == claimed:
        return PassivityVerification("confirmed", req, b, None, _word(claimed), _word(claimed))
    return PassivityVerification("contradicted", req, b,
                                 f"said {_word(claimed)}, but b = {b:.9g} {'>' if passive else '≤'} the sup "
                                 f"(≥ {req:.9g} N·s/m" + (", a 40-digit witness)" if witness else ")"),
                                 _word(claimed), None)


#: relative tolerance of the rendered wall's recomputed passivity bound (its polynomial form loses ≈ u/θ of B at
#: small θ, sampled from θ = 1e-4 up): decided only outside this band of the bound's scale
RENDERED_PASSIVITY_RTOL = 1e-9


def _rendered_bound(device: Device, stiffness: float, damping: float, render: tuple, whole: int,
                    theta: np.ndarray) -> np.ndarray:
    """(T/2)·Re{(1 − e^{−jθ})·e^{−jdθ}·C(e^{jθ})}/(1 − cos θ) with C = (m/T²)·P(z⁻¹)/D(z⁻¹) from the difference
    equation's polynomials (optim.stability.closed_loop_rendered), not from the analysis' V(z)."""
    spec, mass = render
    m, t = device.mass, device.sample_time
    num, den = filter_polynomials(spec, t)
    w = np.exp(-1j * theta)
    one_minus_w = 1.0 - w
    v = np.polyval(num[::-1], w) / np.polyval(den[::-1], w)            # T·V
    c = stiffness + (m / (t * t)) * ((damping * t / m) * v + (mass / m) * v * one_minus_w)
    return (t / 2) * (one_minus_w * np.exp(-1j * whole * theta) * c).real / (1.0 - np.cos(theta))


def verify_rendered_passivity(device: Device, stiffness: float, damping: float, render: tuple,
                              claimed: bool) -> PassivityVerification:
    """The claimed passivity of a rendered wall against the general condition recomputed from the controller's
    polynomials: a uniform grid from θ = 1e-4 (≥ 64 points per turn of the delay's phase), its 6 highest maxima
    polished, and the limit K·T·(d + ½) − B as θ → 0⁺; decided outside :data:`RENDERED_PASSIVITY_RTOL`."""
    whole = math.ceil(device.delay / device.sample_time - 1e-9)

    def f(x: float) -> float:
        return float(_rendered_bound(device, stiffness, damping, render, whole, np.array([x]))[0])

    grid = np.concatenate([np.geomspace(1e-4, 0.05, 300), np.linspace(0.05, math.pi, max(20001, 64 * (whole + 1)))])
    vals = _rendered_bound(device, stiffness, damping, render, whole, grid)
    req = float(np.max(vals))
    for i in np.argsort(vals)[-6:]:
        a, b = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
        r = minimize_scalar(lambda x: -f(x), bounds=(a, b), method="bounded", options={"xatol": 1e-12})
        req = max(req, float(-r.fun))
    req = max(req, stiffness * device.sample_time * (whole + 0.5) - damping)
    b = device.damping
    scale = max(abs(req), stiffness * device.sample_time * (whole + 1), damping,
                abs(render[1]) / device.sample_time, 1e-300)
    if abs(b - req) <= RENDERED_PASSIVITY_RTOL * scale:
        return PassivityVerification("not_checkable", req, b, f"b equals the damping passivity requires to within "
                                                              f"{RENDERED_PASSIVITY_RTOL:g} of its scale")
    passive = b > req
    if passive == claimed:
        return PassivityVerification("confirmed", req, b, None)
    return PassivityVerification("contradicted", req, b,
                                 f"said {'passive' if claimed else 'not passive'}, but b = {b:.9g} "
                                 f"{'>' if passive else '≤'} required {req:.9g} N·s/m")


def _with_labels(v: Verification, device: Device, stiffness: float, damping: float, stable: bool | None,
                 passive: bool | None, t0: float, render: tuple | None = None) -> Verification:
    """Add the checks of a wall's own labels: the closed loop at K itself, and its passivity."""
    plant = sampled_plant(device)
    m, t = device.mass, device.sample_time
    p = _check_point(device, plant, stiffness * t * t / m, damping * t / m, render)
    if passive is None:
        pas = None
    elif render is None:
        pas = verify_passivity(device, stiffness, damping, passive)
    else:
        pas = verify_rendered_passivity(device, stiffness, damping, render, passive)
    verdicts = [v.verdict]
    reasons = [v.reason] if v.reason else []
    if p.stable is None:
        verdicts.append("not_checkable")
        reasons.append(f"the wall itself: {p.reason}")
    elif stable is not None and p.stable != stable:
        verdicts.append("contradicted")
        reasons.append(f"the wall itself is {'stable' if p.stable else 'unstable'}, but was said "
                       f"{'stable' if stable else 'unstable'}")
    if pas is not None:
        verdicts.append(pas.verdict)
        if pas.reason:
            reasons.append(f"passivity: {pas.reason}")
    verdict: Verdict = ("contradicted" if "contradicted" in verdicts else
                        "not_checkable" if "not_checkable" in verdicts else "confirmed")
    words = [v.label] if v.label else []
    if stable is not None:
        words.append(f"the wall (K = {stiffness:.9g} N/m, B = {damping:.9g} N·s/m) is {'stable' if stable else 'unstable'}")
    if passive is not None:
        words.append(_word(passive))
    out = replace(v, verdict=verdict, reason="; ".join(reasons) or None, design_radius=p.radius,
                  design_unstable_poles=p.count, passivity=pas, elapsed_ms=(time.perf_counter() - t0) * 1e3,
                  method=v.method or p.method)
    return labelled(out, "; ".join(words) or None)


def verify_stiffness_design(device: Device, stiffness: float, damping: float, gain_margin_db: float | None,
                            passive: bool | None = None, epsilon: float | None = DEFAULT_EPSILON,
                            critical: float | None = None, render: tuple | None = None) -> Verification:
    """A design (K, B) (``render``: a rendered wall's (velocity filter spec, virtual mass M [kg]), closed with the
    filter's states; None: today's wall): its margin says the critical gain is K·10^(GM/20): check that gain like K_cr at ±``epsilon``
    (the design rung's claim, :func:`claimed_epsilon`; None: it claims no bound), check that K itself is stable (a
    design is always said stable), and, when the design states it, its passivity."""
    t0 = time.perf_counter()
    kc = stiffness * 10.0 ** (gain_margin_db / 20.0) if gain_margin_db is not None else critical
    if epsilon is None:
        v = not_checkable(t0, "the design's rung states no error bound on its K_cr: its margin claims nothing to check")
    else:
        v = verify_critical_stiffness(device, damping, kc, epsilon, render=render)
    if gain_margin_db is not None and kc is not None:
        v = labelled(v, f"gain_margin_db = {gain_margin_db:.9g} (critical stiffness K·10^(GM/20) = {kc:.9g} N/m)")
    if render is None:
        return _with_labels(v, device, stiffness, damping, True, passive, t0)
    return _with_labels(v, device, stiffness, damping, True, passive, t0, render)


def verify_analysis(device: Device, analysis, render: tuple | None = None) -> Verification:
    """Verify an optim.stability.analysis.StabilityAnalysis on whatever rung produced it (``render``: the rendered
    wall's (velocity filter spec, virtual mass M [kg]), closed with the filter's states; None: today's wall).

    Exact and reference answers are checked at ±:data:`DEFAULT_EPSILON`; an approximate rung (linear, grid)
    at ± its own error estimate (its claim), and not at all when it claims no bound.  The labels of a given
    wall (stable, passive) are checked too."""
    t0 = time.perf_counter()
    # the linear rung documents its estimate as within 2× of the true error (optim.stability.analysis): check that claim
    eps = claimed_epsilon(analysis.method, analysis.error_estimate, linear_factor=2.0)
    if eps is None:
        return not_checkable(t0, f"the {analysis.method} rung states no error bound (its estimate is unbounded): "
                                  "there is no claim to check")
    kcr = analysis.critical_stiffness
    above = [c.stiffness for c in analysis.crossovers
             if kcr is not None and c.stiffness > kcr * (1 + 1e-9)] if analysis.method != "linear" else []
    # An approximate rung claims only K_cr ∈ [K(1 − est), K(1 + est)]: check exactly that (stable below, unstable
    # above), with no cap at the next listed crossover (a cap would test a stronger claim than the rung made).
    exact = analysis.method in ("exact", "reference")
    v = verify_critical_stiffness(device, analysis.damping, kcr, eps,
                                  next_crossing=min(above) if above and exact else None, render=render)
    if analysis.stiffness is None:
        return v
    return _with_labels(v, device, analysis.stiffness, analysis.damping, analysis.stable, analysis.passive, t0,
                        render)


# --- force feedforward: K_f,cr of 1 + K_f·D·G_1 --------------------------------------------------------------

def _ff_point(loop, force_gain: float) -> _Point:
    from optim.transparency.closed_loop_feedforward import (
        feedforward_closed_loop,
        feedforward_unstable_count,
    )

    if loop.states <= EIG_MAX_STATES:
        ex = radius_excess(feedforward_closed_loop(loop, force_gain))
        if ex.decided_stable or ex.decided_unstable:
            return _Point(ex.decided_stable, 1.0 + ex.excess, None, EIGEN, None)
    # a closed-loop pole within double precision's reach of the circle is decided in 50-digit mpmath (the plant
    # sampled again by optim.stability.closed_loop_mp.mp_sampled), as the stiffness count does
    return _counted(feedforward_unstable_count(loop, force_gain, PRECISE_DIGITS))


def verify_critical_force_gain(device: Device, human, critical: float | None, order: int | None = None,
                               cutoff_hz: float | None = None, epsilon: float | None = DEFAULT_EPSILON,
                               next_crossing: float | None = None, design_gain: float | None = None) -> Verification:
    """:func:`_critical_force_gain_check`, labelled with the critical force gain (and the designed one) it checks."""
    v = _critical_force_gain_check(device, human, critical, order, cutoff_hz, epsilon, next_crossing, design_gain)
    label = _gain_label("critical_force_gain", critical, "")
    if design_gain is not None:
        label += f"; the designed force_gain = {design_gain:.9g} is stable"
    return labelled(v, label)


def _critical_force_gain_check(device: Device, human, critical: float | None, order: int | None = None,
                               cutoff_hz: float | None = None, epsilon: float | None = DEFAULT_EPSILON,
                               next_crossing: float | None = None, design_gain: float | None = None) -> Verification:
    """Is 1 + K_f·D·G_1 stable at K_f,cr·(1 − ε) and unstable at K_f,cr·(1 + ε)?  ``design_gain``: a
    designed K_f, checked stable too (its spectral radius is reported as design_radius)."""
    from optim.transparency.closed_loop_feedforward import feedforward_loop

    t0 = time.perf_counter()
    loop = feedforward_loop(device, human, order, cutoff_hz)
    design = _ff_point(loop, design_gain) if design_gain is not None else None
    if critical is None or math.isinf(critical):
        probe = 1e3 * (1.0 + device.mass / human.mass)
        p = _ff_point(loop, probe)
        if p.stable is False:
            return Verification("contradicted", p.method, None, None, probe, None, p.radius, None, p.count,
                                (time.perf_counter() - t0) * 1e3, "every K_f was said stable, but this K_f is not")
        return not_checkable(t0, "no finite set of gains proves that every K_f > 0 is stable", method=p.method,
                              gain_above=probe)
    if epsilon is None:
        return not_checkable(t0, "the rung states no error bound on K_f,cr: there is no claim to check")
    eps = epsilon
    if next_crossing is not None and math.isfinite(next_crossing) and next_crossing > critical:
        eps = min(eps, 0.5 * (next_crossing / critical - 1.0))
    k_lo = critical * (1.0 - eps) if eps < 0.5 else critical / (1.0 + eps)
    k_hi = critical * (1.0 + eps)
    lo, hi = _ff_point(loop, k_lo), _ff_point(loop, k_hi)
    out = Verification("not_checkable", _methods(lo, hi), eps, k_lo, k_hi, lo.radius, hi.radius, lo.count, hi.count,
                       0.0, lo.reason or hi.reason)
    reasons = []
    if lo.stable is False:
        reasons.append(f"unstable at K_f = {k_lo:.9g} below the answer")
    if hi.stable is True:
        reasons.append(f"stable at K_f = {k_hi:.9g} above the answer")
    verdict: Verdict = ("contradicted" if reasons else
                        "confirmed" if (lo.stable is True and hi.stable is False) else "not_checkable")
    if design is not None:
        if design.stable is False:
            verdict, reasons = "contradicted", reasons + ["the designed force gain itself is unstable"]
        elif design.stable is None and verdict == "confirmed":
            verdict, reasons = "not_checkable", reasons + [f"the designed force gain: {design.reason}"]
        out = replace(out, design_radius=design.radius, design_unstable_poles=design.count)
    return replace(out, verdict=verdict, reason="; ".join(reasons) or out.reason if verdict != "confirmed" else None,
                   elapsed_ms=(time.perf_counter() - t0) * 1e3)


def verify_force_feedforward(device: Device, analysis, order: int | None, cutoff_hz: float | None) -> Verification:
    """Verify an optim.transparency.feedforward_ladder.ForceFeedforwardAnalysis on its rung (ε as for the stiffness rungs)."""
    t0 = time.perf_counter()
    eps = claimed_epsilon(analysis.method, analysis.error_estimate)
    if eps is None:
        return not_checkable(t0, f"the {analysis.method} rung states no error bound: there is no claim to check")
    kcr = analysis.critical_force_gain
    above = [c.force_gain for c in analysis.crossovers if math.isfinite(kcr) and c.force_gain > kcr * (1 + 1e-9)]
    return verify_critical_force_gain(device, analysis.human, kcr, order, cutoff_hz, eps,
                                      next_crossing=min(above) if above else None)


# --- the stability boundary: every point, the optimum's record -----------------------------------------------

def verify_boundary(device: Device, boundary, render: tuple | None = None,
                    epsilon: float = DEFAULT_EPSILON) -> Verification:
    """Verify every K_cr(B) of an optim.stability.boundary.Boundary; the record is the optimum's, the verdict the worst
    over the points, and the reason counts them (a contradicted point is named)."""
    t0 = time.perf_counter()
    counts = {"confirmed": 0, "contradicted": 0, "not_checkable": 0}
    bad: list[str] = []
    for p in boundary.points:
        k = p.critical_stiffness if math.isfinite(p.critical_stiffness) else None
        v = verify_critical_stiffness(device, p.damping, k, epsilon, render=render)
        counts[v.verdict] += 1
        if v.verdict != "confirmed" and len(bad) < 3:
            bad.append(f"B = {p.damping:.6g}: {v.verdict} ({v.reason})")
    opt = boundary.optimum
    best = verify_critical_stiffness(device, opt.damping,
                                     opt.critical_stiffness if math.isfinite(opt.critical_stiffness) else None, epsilon,
                                     render=render)
    counts[best.verdict] += 1
    verdict: Verdict = ("contradicted" if counts["contradicted"] else
                        "not_checkable" if counts["not_checkable"] else "confirmed")
    n = sum(counts.values())
    reason = (f"{n} points (the optimum included): {counts['confirmed']} confirmed, {counts['contradicted']} "
              f"contradicted, {counts['not_checkable']} not checkable" + ("; " + "; ".join(bad) if bad else ""))
    return labelled(replace(best, verdict=verdict, reason=reason, elapsed_ms=(time.perf_counter() - t0) * 1e3),
                    f"critical_stiffness at each of the {n} points (the optimum's: {best.label})")
