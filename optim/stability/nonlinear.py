"""Encoder quantisation and Coulomb friction: the passive wall, the limit cycles, the regime (issue 31).

Passivity (Abbott & Okamura, IEEE T-RO 21(5):952-964, 2005, main theorem): a virtual spring K on a
mass with viscous damping b and Coulomb friction f_c, sampled (ZOH) at T, its position read by an
encoder of resolution q, is passive if and only if

    K ≤ min(2b/T, 2f_c/q),

with two decoupled ways to fail: K > 2b/T (the sampled spring's energy leak beats the viscous
damping: instability), K > 2f_c/q (a one-count force step K·q beats the friction 2f_c it must overcome
back and forth across a count: active "tactile" chatter at the quantisation scale).  The theorem is
for B = 0, no delay and a rigid device; for anything else (virtual damping, delay, a cable) this
module combines zwidth's delayed passivity condition (optim.stability.passivity) with 2f_c/q and says
``covered = False``: no proof is claimed there.

Limit cycles (Diolaiti, Niemeyer, Barbagli & Salisbury, IEEE T-RO 22(2):256-268, 2006, use a
describing function as one of their tools; the harmonic balance below is this module's own): for a
sinusoid x = A·sin ωt at the encoder,

  * the mid-tread quantiser q·round(x/q) acts as the gain (Gelb & Vander Velde's staircase DF)
        N_q(A) = (4q/πA)·Σ_{i=1..n} √(1 − ((2i−1)q/2A)²),  n = ⌊A/q + ½⌋,   N_q = 0 for A < q/2,
    which peaks at 4/π for A = q/√2 and tends to 1 for A ≫ q;
  * Coulomb friction f_c·sign(v) on the motor mass acts as a viscous damping b_f = 4f_c/(π·A·ω).

A cycle of amplitude A balances when the quantised wall's gain is the critical stiffness of the
device damped by b + b_f at the virtual damping seen through the quantiser:

    g(A) = N_q(A)·K − K_cr(b + b_f(A, ω); N_q(A)·B) = 0,   ω = ω_cr of that K_cr,

with K_cr zwidth's exact critical stiffness (delay and cable included: the loop the DF linearises).
g > 0 means the loop at that amplitude is unstable (the amplitude grows), g < 0 that it decays.  A
root where g falls through 0 as A grows is a stable (attracting) cycle; where it rises, an unstable one
(a threshold: larger motions grow).  The DF assumes a sinusoid: near the Nyquist frequency and for
cycles of one or two counts it is rough; docs/quantisation.md states the error measured by simulation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.optimize import brentq

from models.device import Device
from models.velocity_filter import Rendering
from optim.domain import DELTA_MAX
from optim.errors import InputError
from optim.stability.margins import CriticalStiffness, critical_stiffness
from optim.stability.passivity import max_passive_stiffness
from optim.stability.passivity_rendered import rendered_passivity
from optim.stability.quantised_orbits import Orbit, find_orbits
from optim.stability.rendered import rendered_critical_stiffness

__all__ = ["ABBOTT_OKAMURA", "PassiveLimit", "LimitCycle", "NonlinearAnalysis", "Regime", "quantizer_gain",
           "friction_damping", "abbott_okamura_limit", "passive_stiffness_limit", "balance",
           "predict_limit_cycle", "analyse_nonlinear", "DF_ERROR", "ORBIT_ERROR"]

Regime = Literal["passive", "stable_not_passive", "limit_cycle", "unstable", "undetermined"]

ABBOTT_OKAMURA = ("Abbott & Okamura, IEEE T-RO 21(5):952-964, 2005, main theorem: passive iff "
                  "K ≤ min(2b/T, 2f_c/q) (virtual spring, B = 0, no delay, rigid device)")
#: The describing function's error as measured on random walls (docs/quantisation.md); stated in every answer.
DF_ERROR = ("describing-function harmonic balance (sinusoidal-input quantiser gain, Coulomb friction as "
            "4f_c/(πAω) damping, zwidth's exact K_cr for the linear part); an approximation, not a bound: "
            "docs/quantisation.md gives its measured error against long simulations")
#: The exact orbit's error (docs/quantisation.md): none in the orbit itself; which orbit a motion settles into
#: when several coexist is not decided by it.
ORBIT_ERROR = ("the orbit is exact (sampled plant, delay, cable, controller and quantiser without approximation); "
               "where several orbits coexist the one reported is the one with the widest rounding margin, and a "
               "motion may settle into another: docs/quantisation.md gives the measured spread")
_GRID = 48
_PER_DECADE = 6
_OMEGA_ITER = 4
#: above this many counts the quantiser's DF is 1 to within ~(q/A)^1.5 < 1e-9; the sum is not formed
_DF_TERMS_MAX = 1_000_000


def quantizer_gain(amplitude: float, q: float | None) -> float:
    """N_q(A): describing function of the mid-tread quantiser q·round(x/q) for x = A·sin ωt [-]."""
    if q is None:
        return 1.0
    if amplitude < q / 2:
        return 0.0
    n = int(math.floor(amplitude / q + 0.5))
    if n > _DF_TERMS_MAX:
        return 1.0
    r = (2 * np.arange(1, n + 1) - 1) * q / (2 * amplitude)
    return float(4 * q / (math.pi * amplitude) * np.sum(np.sqrt(np.clip(1 - r * r, 0.0, None))))


def friction_damping(friction: float | None, amplitude: float, omega: float) -> float:
    """b_f = 4f_c/(π·A·ω) [N·s/m]: the viscous damping that dissipates what Coulomb friction does per cycle."""
    if not friction:
        return 0.0
    return 4 * friction / (math.pi * amplitude * omega)


@dataclass(frozen=True)
class PassiveLimit:
    stiffness: float
    """[N/m] the largest passive K (a supremum)."""
    sampling_term: float
    """[N/m] 2b/T (Abbott & Okamura) or, outside the theorem, zwidth's delayed Colgate–Schenkel limit at B."""
    quantization_term: float
    """[N/m] 2f_c/q; inf without an encoder resolution, 0 with one and no friction."""
    binding: Literal["sampling", "quantization"]
    source: str
    covered: bool
    reason: str


def abbott_okamura_limit(damping: float, sample_time: float, friction: float | None,
                         resolution: float | None) -> tuple[float, float]:
    """(2b/T, 2f_c/q) [N/m] of Abbott & Okamura's theorem (q absent: inf; f_c absent: 0)."""
    quant = math.inf if resolution is None else 2 * (friction or 0.0) / resolution
    return 2 * damping / sample_time, quant


def _filtered(rendering: Rendering | None, damping: float) -> bool:
    """The velocity filter or virtual mass changes the wall: C ≠ K + B(1 − z⁻¹)/T.  (With B = 0 and M = 0 the
    filter multiplies nothing.)"""
    return rendering is not None and not rendering.is_default and (damping > 0 or rendering.mass != 0)


def _rendered_passive_limit(device: Device, damping: float, rendering: Rendering, start: float) -> float:
    """[N/m] the largest K that optim.stability.passivity_rendered calls passive at (B, M, filter): bracketed by
    doubling from ``start`` and bisected to 1e-7 relative (0 when not even 1e-6 of ``start`` is passive)."""
    def ok(k: float) -> bool:
        return rendered_passivity(device, k, damping, rendering).passive
    lo, hi = 0.0, max(start, 1e-9 * device.stiffness_scale)
    if not ok(hi) and not ok(1e-6 * hi):
        return 0.0
    for _ in range(200):
        if not ok(hi):
            break
        lo, hi = hi, 2 * hi
    else:
        return math.inf
    while hi - lo > 1e-7 * hi:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if ok(mid) else (lo, mid)
    return lo


def passive_stiffness_limit(device: Device, damping: float, rendering: Rendering | None = None) -> PassiveLimit:
    """The largest passive K of the quantised, Coulomb-damped wall with virtual damping B = ``damping`` (and the
    controller's velocity filter and virtual mass, ``rendering``)."""
    sampling, quant = abbott_okamura_limit(device.damping, device.sample_time, device.coulomb_friction,
                                           device.encoder_resolution)
    filtered = _filtered(rendering, damping)
    outside = [w for w, yes in (("virtual damping B > 0", damping > 0), ("loop delay", device.delay > 0),
                                ("cable transmission", device.cable is not None),
                                ("velocity filter or virtual mass", filtered)) if yes]
    if filtered:
        assert rendering is not None
        sampling = _rendered_passive_limit(device, damping, rendering, max_passive_stiffness(device, damping))
        source = ("extension, not proven: min(zwidth's passivity bound of the filtered wall (optim.stability."
                  "passivity_rendered) at B, M and the velocity filter, 2f_c/q of " + ABBOTT_OKAMURA + ")")
        reason = "outside Abbott & Okamura's theorem (" + ", ".join(outside) + "): covered = false"
    elif outside:
        sampling = max_passive_stiffness(device, damping)
        source = ("extension, not proven: min(zwidth's delayed Colgate–Schenkel limit at B (ARCHITECTURE.md "
                  "'Passivity'), 2f_c/q of " + ABBOTT_OKAMURA + ")")
        reason = "outside Abbott & Okamura's theorem (" + ", ".join(outside) + "): covered = false"
    else:
        source, reason = ABBOTT_OKAMURA, "the theorem's case (B = 0, no delay, rigid device)"
    binding: Literal["sampling", "quantization"] = "sampling" if sampling <= quant else "quantization"
    return PassiveLimit(min(sampling, quant), sampling, quant, binding, source, not outside, reason)


@dataclass(frozen=True)
class Balance:
    """One point of the harmonic balance at amplitude A."""

    amplitude: float
    gain: float
    """N_q(A)·K [N/m]."""
    critical: float
    """K_cr(b + b_f; N_q·B) [N/m] (inf when every K is stable)."""
    omega: float | None
    """ω_cr [rad/s] of that K_cr."""

    @property
    def excess(self) -> float:
        """g(A) = N_q·K − K_cr, scaled by K: > 0 grows, < 0 decays."""
        return (self.gain - self.critical) / max(self.gain, 1e-300) if self.gain > 0 else -1.0


def _damped(device: Device, extra: float) -> Device:
    """The device with ``extra`` viscous damping on the motor-side mass (where Coulomb friction acts)."""
    if extra == 0.0:
        return device
    if device.cable is None:
        return device.model_copy(update={"damping": device.damping + extra})
    cable = device.cable.model_copy(update={"motor_damping": device.cable.motor_damping + extra})
    return device.model_copy(update={"cable": cable, "damping": device.damping + extra})


def _kcr(device: Device, damping: float, rendering: Rendering | None, gain: float = 1.0) -> CriticalStiffness:
    """K_cr of the wall whose controller C = K + B·V + M·A is seen through the gain ``gain`` (the quantiser's DF):
    N·B and N·M with the velocity filter (optim.stability.rendered), N·B alone without."""
    if rendering is None or rendering.is_default:
        return critical_stiffness(device, gain * damping)
    return rendered_critical_stiffness(device, gain * damping, Rendering(rendering.velocity, gain * rendering.mass))


def balance(device: Device, stiffness: float, damping: float, amplitude: float,
            rendering: Rendering | None = None) -> Balance:
    """g(A) of the module docstring, ω found by a few fixed-point passes (b_f depends on ω)."""
    n = quantizer_gain(amplitude, device.encoder_resolution)
    if n == 0.0:
        return Balance(amplitude, 0.0, math.inf, None)
    f_c = device.coulomb_friction
    res = _kcr(device, damping, rendering, n)
    for _ in range(_OMEGA_ITER if f_c else 0):
        if res.crossover_frequency is None:
            break
        extra = friction_damping(f_c, amplitude, res.crossover_frequency)
        if (device.damping + extra) * device.sample_time / device.mass > DELTA_MAX:
            # friction's damping beyond the numerics' domain at this amplitude: K_cr grows with the damping
            # (chapter eq. 10), far past any K the request can carry; the amplitude decays
            return Balance(amplitude, n * stiffness, math.inf, None)
        res = _kcr(_damped(device, extra), damping, rendering, n)
    kcr = math.inf if res.critical_stiffness is None else res.critical_stiffness
    return Balance(amplitude, n * stiffness, kcr, res.crossover_frequency)


@dataclass(frozen=True)
class LimitCycle:
    exists: bool
    """a stable (attracting) cycle is predicted."""
    amplitude: float | None
    """[m] amplitude A of x_r (half peak-to-peak) of the outermost stable cycle."""
    frequency_hz: float | None
    """[Hz] its frequency ω/2π."""
    threshold_amplitude: float | None
    """[m] an unstable cycle above which motions grow without bound (a linearly unstable wall that friction or
    the quantiser's dead band holds for small motions); None when there is none."""
    method: str
    error: str


def _amplitudes(device: Device, damping: float, rendering: Rendering | None) -> tuple[float, float]:
    """[m] the amplitudes where the balance can change sign: from half a count (or where friction's damping is
    1e3 times b) up to 1e4 counts (N_q = 1 within ~1e-6) and to where friction's damping is 1e-4 of b."""
    q, f_c = device.encoder_resolution, device.coulomb_friction or 0.0
    lo, hi = math.inf, 0.0
    if q is not None:
        lo, hi = q / 2, 1e4 * q
    if f_c > 0:
        lin = _kcr(device, damping, rendering).crossover_frequency or math.pi / device.sample_time
        b_ref = max(device.damping, 1e-6 * device.mass / device.sample_time)
        a_f = 4 * f_c / (math.pi * lin * b_ref)      # where b_f(A, ω_cr) = b
        lo, hi = min(lo, 1e-3 * a_f), max(hi, 1e4 * a_f)
    return lo, hi


def predict_limit_cycle(device: Device, stiffness: float, damping: float,
                        rendering: Rendering | None = None) -> tuple[LimitCycle, float]:
    """The harmonic balance scanned over amplitudes; returns the cycle and g far above every scale (the linear
    loop: N_q = 1, no friction damping).  Without friction, an exact periodic orbit of the quantised loop
    (optim.stability.quantised_orbits) replaces the describing function's answer when one is found."""
    lo, hi = _amplitudes(device, damping, rendering)
    linear = _kcr(device, damping, rendering)
    lin = linear.critical_stiffness
    g_far = (stiffness - (math.inf if lin is None else lin)) / stiffness
    if g_far <= 0 and device.encoder_resolution is not None and not device.coulomb_friction:
        angle = None if linear.crossover_frequency is None else linear.crossover_frequency * device.sample_time
        orbits = find_orbits(device, stiffness, damping, angle, rendering)
        if orbits:
            return _orbit_cycle(orbits), g_far
    amps = np.geomspace(lo * (1 + 1e-9), hi, max(_GRID, int(_PER_DECADE * math.log10(hi / lo))))
    g = [balance(device, stiffness, damping, float(a), rendering).excess for a in amps] + [g_far]
    amps = np.append(amps, math.inf)
    stable: list[float] = []
    unstable: list[float] = []
    for i in range(len(amps) - 1):
        if (g[i] > 0) != (g[i + 1] > 0):
            a = _root(device, stiffness, damping, float(amps[i]), float(amps[i + 1]), rendering) \
                if math.isfinite(amps[i + 1]) else float(amps[i])
            (stable if g[i] > 0 else unstable).append(a)
    threshold = unstable[-1] if unstable and g_far > 0 else None
    method = f"describing function (harmonic balance on {len(amps) - 1} amplitudes, roots by Brent's method)"
    if not stable or (threshold is not None and stable[-1] > threshold):
        return LimitCycle(False, None, None, threshold, method, DF_ERROR), g_far
    a = stable[-1]
    bal = balance(device, stiffness, damping, a, rendering)
    freq = None if bal.omega is None else bal.omega / (2 * math.pi)
    return LimitCycle(True, a, freq, threshold, method, DF_ERROR), g_far


def _orbit_cycle(orbits: list[Orbit]) -> LimitCycle:
    """The found orbit that clears the rounding thresholds by the widest margin (the most robust one; on the
    random walls of docs/quantisation_runs.md the one a release settles into)."""
    best = max(orbits, key=lambda o: o.margin)
    method = (f"exact periodic orbit of the sampled quantised loop (optim.stability.quantised_orbits: period "
              f"{best.period} samples, force levels up to ±{best.levels} counts, every sample ≥ {best.margin:.2g} "
              f"counts from a rounding threshold; {len(orbits)} orbit(s) found)")
    return LimitCycle(True, best.amplitude, best.frequency_hz, None, method, ORBIT_ERROR)


def _root(device: Device, stiffness: float, damping: float, a: float, b: float,
          rendering: Rendering | None = None) -> float:
    def f(x: float) -> float:
        return balance(device, stiffness, damping, math.exp(x), rendering).excess
    try:
        return math.exp(brentq(f, math.log(a), math.log(b), xtol=1e-6))
    except ValueError:   # the quantiser's DF is not continuous at the count thresholds: the bracket's middle
        return math.sqrt(a * b)


@dataclass(frozen=True)
class NonlinearAnalysis:
    passive: PassiveLimit
    limit_cycle: LimitCycle
    regime: Regime | None
    """None when no stiffness was given (there is no wall to judge)."""
    reason: str


def analyse_nonlinear(device: Device, stiffness: float | None, damping: float,
                      rendering: Rendering | None = None) -> NonlinearAnalysis | None:
    """The passive limit, the predicted cycle and the regime of the wall (K, B) on a device with an encoder
    resolution or a Coulomb friction; None for a device with neither.  Without a stiffness only the passive
    limit is answered (regime None).  ``rendering``: the controller's velocity filter and virtual mass (None: the
    backward difference, today's wall), in the passive limit, the describing function and the exact orbits."""
    if not device.nonlinear:
        return None
    try:
        with np.errstate(over="raise", invalid="raise"):
            return _analyse(device, stiffness, damping, rendering)
    except (FloatingPointError, OverflowError, ZeroDivisionError) as exc:
        raise InputError("device", "the encoder resolution and Coulomb friction leave the numerically "
                         "representable range of the harmonic balance") from exc


#: σ = f_c/(K·q) below which a frictionless orbit makes the call unsure (docs/quantisation.md): the describing
#: function smooths friction into 4f_c/(πAω) damping and finds no cycle, the exact orbit search ignores friction and
#: finds one; on the random walls of docs/quantisation_runs.md walls with σ ≈ 0.02 cycled, walls with σ ≥ 0.1 settled.
SIGMA_UNSURE = 0.1


def _small_friction_orbit(device: Device, stiffness: float, damping: float, rendering: Rendering | None) -> str | None:
    """The reason the call is undetermined, or None: friction present but small (σ < SIGMA_UNSURE) and the loop
    without it has an exact orbit."""
    q, f_c = device.encoder_resolution, device.coulomb_friction
    if q is None or not f_c or f_c / (stiffness * q) >= SIGMA_UNSURE:
        return None
    bare = device.model_copy(update={"coulomb_friction": None})
    lin = _kcr(bare, damping, rendering)
    angle = None if lin.crossover_frequency is None else lin.crossover_frequency * device.sample_time
    orbits = find_orbits(bare, stiffness, damping, angle, rendering)
    if not orbits:
        return None
    best = max(orbits, key=lambda o: o.margin)
    return (f"undetermined: without friction the loop has an exact orbit of {best.amplitude:.3g} m at "
            f"{best.frequency_hz:.3g} Hz, and the friction σ = f_c/(Kq) = {f_c / (stiffness * q):.3g} < "
            f"{SIGMA_UNSURE:g} is too small for the describing function (no cycle) to be trusted to stop it")


def _analyse(device: Device, stiffness: float | None, damping: float,
             rendering: Rendering | None) -> NonlinearAnalysis:
    limit = passive_stiffness_limit(device, damping, rendering)
    if stiffness is None:
        none = LimitCycle(False, None, None, None, "none: no stiffness given", DF_ERROR)
        return NonlinearAnalysis(limit, none, None, "no wall given: the passive limit alone is answered")
    cycle, g_far = predict_limit_cycle(device, stiffness, damping, rendering)
    if g_far > 0:
        why = ("the linear loop is unstable at large amplitude (K > K_cr)"
               + (f"; motions below {cycle.threshold_amplitude:.3g} m are held by friction or the dead band"
                  if cycle.threshold_amplitude is not None else ""))
        return NonlinearAnalysis(limit, cycle, "unstable", why)
    passive = stiffness <= limit.stiffness
    if passive and limit.covered:
        note = "" if not cycle.exists else ("; the describing function predicts a cycle the theorem excludes "
                                            "(its error, not a cycle)")
        cycle = LimitCycle(False, None, None, None, cycle.method, cycle.error) if cycle.exists else cycle
        return NonlinearAnalysis(limit, cycle, "passive", f"K ≤ {limit.stiffness:.6g} N/m ({limit.source})" + note)
    if cycle.exists:
        how = "the exact orbit" if cycle.method.startswith("exact") else "the harmonic balance"
        return NonlinearAnalysis(limit, cycle, "limit_cycle",
                                 f"{how} holds at A = {cycle.amplitude:.3g} m: a sustained oscillation")
    unsure = _small_friction_orbit(device, stiffness, damping, rendering)
    if unsure is not None and not passive:
        return NonlinearAnalysis(limit, cycle, "undetermined", unsure)
    if passive:
        return NonlinearAnalysis(limit, cycle, "passive", f"K ≤ {limit.stiffness:.6g} N/m by the extension "
                                 "(covered = false) and no cycle predicted")
    return NonlinearAnalysis(limit, cycle, "stable_not_passive",
                             f"K > {limit.stiffness:.6g} N/m ({limit.binding} term) but no cycle is predicted and "
                             "the linear loop is stable")
