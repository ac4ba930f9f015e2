"""K_f,cr of the force-feedforward loop (chapter §5) on any rung of the accuracy ladder.

Rungs (ARCHITECTURE.md): ``linear`` — the chapter's closed form eq. 33,
K_f,cr ≈ 1 + m/m_h (the flat inertial part of G_1, valid for large delays);
``grid`` — a fixed log grid of ``grid_points`` angles with linear interpolation,
as a naive tool would; ``exact`` — every crossover bracketed and refined
(optim.transparency.feedforward); ``reference`` — 40-digit mpmath residues and bisection
(optim.transparency.feedforward_reference).  Every answer says which rung produced it, what
it cost and how far it may be off.

The linear rung's error estimate
--------------------------------
Eq. 33 replaces G_1 by its plateau ρ_h = m_h/(m + m_h).  What it drops is, in
order of size on the chapter's devices:

1. the sampled sensor lag, the delay and the filter, which decide where the phase
   reaches −π and how much they attenuate there (at no delay the LHifAM crosses at
   the Nyquist frequency where the sensor passes 1/10: K_f,cr is ten times eq. 33);
2. a lightly damped cable mode, whose resonant peak can put a crossing far below
   eq. 33 (LHifAM cable, no filter: K_f,cr ≈ 1.09);
3. the grasp's stiffness and damping, which bend G_1 away from the plateau at low
   frequency.

The estimate evaluates a *plateau model* in which (1) is kept exactly — ρ_h times
the ZOH-sampled first-order sensor lag with the whole and fractional delay
(closed form) times D(z) — and finds its first crossing by marching in steps the
delay's and the filter's phase cannot outrun, then bisecting (scalar arithmetic,
~0.05-0.2 ms); (2) and (3) are bounded by the continuous ratio R(jω) = G_1,c(jω)/ρ_h of
the full and the plateau model at that crossing and at the cable mode's peak.
The estimate is |K_lin/K_a − 1| + 2·|R(jω_x) − 1| with K_a the lower of the plateau
crossing and the peak bound; the benchmark (bench/accuracy_vs_time.py) and
tests/optim/transparency/test_feedforward_ladder.py check that the true error stays within 2×.
"""

from __future__ import annotations

import cmath
import math
import time
from dataclasses import dataclass

import numpy as np

from models.device import Device, Human
from models.feedforward import feedforward_plant
from models.filters import ButterworthLowPass, butterworth_polynomial
from optim.errors import InputError
from optim.stability.analysis import DEFAULT_GRID_POINTS, check_rung
from optim.transparency.feedforward import ForceCrossover, critical_force_gain, resolve_human, worst_case_force_gain
from optim.transparency.feedforward_reference import REFERENCE_DIGITS, reference_critical_force_gain

__all__ = ["ForceFeedforwardAnalysis", "analyse_force_feedforward", "linear_force_gain_error",
           "grid_critical_force_gain", "EXACT_REL_ERROR"]

#: Claimed relative error of the exact rung: measured ≤ 2e-15 against the 40-digit reference on the
#: benchmark suite (docs/accuracy.md); the claim leaves room for ill-conditioned resolvents.
EXACT_REL_ERROR = 1e-12
_GRID_LOW = 1e-4            # lowest angle of the grid rung [rad/sample]


@dataclass(frozen=True)
class ForceFeedforwardAnalysis:
    critical_force_gain: float
    """K_f,cr [dimensionless]; inf when no K_f > 0 destabilises the loop."""
    crossover_frequency: float | None
    """ω [rad/s] of the crossover that sets K_f,cr (None on the linear rung: eq. 33 has no frequency)."""
    crossovers: tuple[ForceCrossover, ...]
    worst_case_force_gain: float
    """1 + m/m_h, eq. 33."""
    human: Human
    human_source: str
    method: str
    elapsed_ms: float
    error_estimate: float
    """Relative error bound (exact, reference, grid) or estimate (linear) of critical_force_gain."""
    error_source: str
    reason: str | None = None


# ---------------------------------------------------------------- linear rung (eq. 33) and its estimate

def _sensor_zoh(theta: float, tau: float, d: int, f: float) -> complex:
    """ZOH-sampled 1/(1 + τs) (τ in samples) with delay d + f, closed form (modified z-transform).

    G_s(z) = z^{−d}·[(1 − a^{1−f})·z + (a^{1−f} − a)]/(z·(z − a)), a = e^{−1/τ}; τ = 0 gives z^{−d−1}
    (the sensor reads at kT⁻, models/feedforward.py).  Scalar: this is the linear rung's cost.
    """
    z = cmath.exp(1j * theta)
    a = math.exp(-1.0 / tau) if tau > 0 else 0.0
    am = a ** (1.0 - f) if tau > 0 else 0.0
    return z ** (-d) * ((1.0 - am) * z + (am - a)) / (z * (z - a))


def _continuous_ratio(device: Device, human: Human, omega: float) -> complex:
    """R(jω) = [Z_h·G_c/(1 + Z_h·G_d)](jω)/ρ_h, the full continuous plant over its plateau (no sensor)."""
    s = 1j * omega
    zh = human.mass * s * s + human.damping * s + human.stiffness
    rho = human.mass / (device.mass + human.mass)
    if device.cable is None:
        g = zh / (device.mass * s * s + device.damping * s + zh)
    else:
        c = device.cable
        p_r = c.motor_mass * s * s + (c.motor_damping + c.damping) * s + c.stiffness
        p_d = c.body_mass * s * s + (c.body_damping + c.damping) * s + c.stiffness
        link = c.damping * s + c.stiffness
        g = zh * link / (p_r * p_d - link * link + zh * p_r)
    return complex(g / rho)


def _mode_frequencies(device: Device, human: Human) -> list[float]:
    """ω [rad/s] of the lightly damped (ζ < 0.2) poles of the cable device held by the human."""
    if device.cable is None:
        return []
    c = device.cable
    p_r = np.array([c.motor_mass, c.motor_damping + c.damping, c.stiffness])
    p_d = np.array([c.body_mass, c.body_damping + c.damping, c.stiffness])
    link = np.array([c.damping, c.stiffness])
    zh = np.array([human.mass, human.damping, human.stiffness])
    # np.convolve is polynomial multiplication; the quartic's roots are the held device's modes
    den = np.convolve(p_r, p_d) + np.convolve(zh, p_r) - np.concatenate([[0.0, 0.0], np.convolve(link, link)])
    return [abs(r.imag) for r in np.roots(den) if r.imag != 0 and -r.real < 0.2 * abs(r)]


def _butterworth_scalar(theta: float, cutoff_angle: float, order: int) -> complex:
    """D(e^{jθ}) = 1/P_n(j·tan(θ/2)/tan(θ_c/2)) for θ < π (models/filters.py, scalar for speed)."""
    nu = 1j * math.tan(0.5 * theta) / math.tan(0.5 * cutoff_angle)
    p = 0j
    for a in butterworth_polynomial(order):
        p = p * nu + a
    return 1.0 / p


def _plateau_crossing(device: Device, human: Human, filt: ButterworthLowPass | None) -> tuple[float, float]:
    """(K_a, θ_x) of the plateau model ρ_h·G_s·D: its lowest crossing with the positive real axis.

    Scalar complex arithmetic throughout: this is the cost of the linear rung's estimate.
    """
    d, f = divmod(device.delay_samples, 1.0)
    d, f = int(d), float(f)
    tau = device.force_sensor.time_constant / device.sample_time if device.force_sensor is not None else 0.0
    rho = human.mass / (device.mass + human.mass)

    def loop(theta: float) -> complex:
        g = rho * _sensor_zoh(theta, tau, d, f)
        if filt is not None:
            g *= _butterworth_scalar(theta, filt.cutoff_angle, filt.order)
        return g

    top = math.pi * (1 - 1e-9) if filt is not None else math.pi
    # the plateau model's phase falls monotonically (lags only): march until Im g changes sign with
    # Re g < 0 (h = −1/g real and positive), in steps the delay's phase cannot outrun
    # (a cutoff below 0.05 rad/sample is passed in the geometric part; above it the filter's phase turns
    # no faster than at θ_c = 0.05, and a step of 0.3·θ_c would march ~1/θ_c steps: a hang for tiny θ_c)
    step = min(0.05, 0.5 / (d + 1), 0.3 * max(filt.cutoff_angle, 0.05) if filt is not None else 1.0)
    lo, g_lo = 1e-3, loop(1e-3)
    while lo < top:
        hi = min(top, lo + step if lo >= 0.05 else lo * 1.3)
        g_hi = loop(hi)
        if g_lo.imag * g_hi.imag < 0 and g_lo.real + g_hi.real < 0:
            fa = g_lo.imag
            for _ in range(30):
                m = 0.5 * (lo + hi)
                fm = loop(m).imag
                if (fm < 0) == (fa < 0):
                    lo, fa = m, fm
                else:
                    hi = m
                if hi - lo < 1e-9 * hi:
                    break
            th = 0.5 * (lo + hi)
            return 1.0 / abs(loop(th)), th
        lo, g_lo = hi, g_hi
    if filt is None and g_lo.real < 0:
        return -1.0 / g_lo.real, math.pi                 # Nyquist crossing (eq. 32)
    return math.inf, math.pi


def linear_force_gain_error(device: Device, human: Human, filt: ButterworthLowPass | None = None) -> float:
    """Estimate of |K_lin/K_f,cr − 1| for eq. 33 (module docstring)."""
    k_lin = worst_case_force_gain(device, human)
    k_a, theta_x = _plateau_crossing(device, human, filt)
    t = device.sample_time
    r_x = _continuous_ratio(device, human, theta_x / t)
    # the plateau crossing moves by the ratio's gain and, through its phase, along the slope of the
    # loop's gain: both are O(|R − 1|); the factor 2 covers the second.
    k_cand = [k_a / abs(r_x)] if math.isfinite(k_a) else []
    d, f = divmod(device.delay_samples, 1.0)
    tau = device.force_sensor.time_constant / t if device.force_sensor is not None else 0.0
    for w in _mode_frequencies(device, human):
        th = w * t
        if th < math.pi:
            g = abs(_continuous_ratio(device, human, w)) * human.mass / (device.mass + human.mass)
            g *= abs(_sensor_zoh(th, tau, int(d), float(f)))
            if filt is not None:
                g *= abs(_butterworth_scalar(th, filt.cutoff_angle, filt.order))
            k_cand.append(1.0 / g)   # a resonant peak above 1/K_f crosses −π nearby: a lower bound candidate
    if not k_cand:
        return math.inf
    k_a = min(k_cand)
    return abs(k_lin / k_a - 1.0) + 2.0 * abs(r_x - 1.0)


# ---------------------------------------------------------------- grid rung

def grid_critical_force_gain(device: Device, human: Human, filt: ButterworthLowPass | None,
                             points: int) -> tuple[float, float | None, tuple[ForceCrossover, ...], float]:
    """K_f,cr on a fixed log grid of θ from 1e-4 to π (no refinement): (K_f,cr, ω, crossovers, error estimate).

    Linear interpolation of Im h̃ between samples, K_f from the interpolated 1/|D·G_1|; the error
    estimate is the relative change of K_f across the bracketing interval (the interpolated root can sit
    anywhere in it when Im h̃ is curved: half the change understated the error 2.7× on the accuracy suite's
    cable, 30 Hz, 50-sample case).
    """
    plant = feedforward_plant(device, human)
    top = math.pi * (1 - 1e-9) if filt is not None else math.pi   # D(−1) = 0: no finite K_f there
    theta = np.geomspace(_GRID_LOW, top, points)
    g = plant.response(theta)
    if filt is not None:
        g = g * filt.response(theta)
    h = -1.0 / g
    im, re = h.imag, h.real
    idx = np.nonzero(np.sign(im[:-1]) * np.sign(im[1:]) < 0)[0]
    found, errs = [], []
    for i in idx:
        w = im[i] / (im[i] - im[i + 1])
        k = re[i] + w * (re[i + 1] - re[i])
        if k > 0:
            found.append(ForceCrossover(frequency=(theta[i] + w * (theta[i + 1] - theta[i])) / device.sample_time,
                                        force_gain=float(k)))
            errs.append(abs(re[i + 1] - re[i]) / abs(k))
    if filt is None and re[-1] > 0:
        found.append(ForceCrossover(frequency=math.pi / device.sample_time, force_gain=float(re[-1])))
        errs.append(0.0)
    if not found:
        return math.inf, None, (), math.inf
    j = int(np.argmin([c.force_gain for c in found]))
    return found[j].force_gain, found[j].frequency, tuple(found), errs[j]


# ---------------------------------------------------------------- dispatcher

def analyse_force_feedforward(device: Device, filt: ButterworthLowPass | None = None, human: Human | None = None,
                              method: str = "exact", grid_points: int = DEFAULT_GRID_POINTS) -> ForceFeedforwardAnalysis:
    """K_f,cr of 1 + K_f·D·G_1 on the chosen rung (ValueError names a bad field)."""
    check_rung(method, grid_points)
    if filt is not None and not math.isclose(filt.sample_time, device.sample_time, rel_tol=1e-12):
        raise InputError("filter", "its sample_time must be the device's sample_time")
    t0 = time.perf_counter()
    hm, source = resolve_human(device, human)
    worst = worst_case_force_gain(device, hm)
    reason = None
    crossovers: tuple[ForceCrossover, ...]
    if method == "linear":
        kcr, w, crossovers = worst, None, ()
        err = linear_force_gain_error(device, hm, filt)
        src = ("eq. 33 keeps only the inertial plateau m_h/(m + m_h) of G_1: estimate from the sampled sensor "
               "lag, delay and filter at the plateau model's crossing, the cable mode's peak and the grasp")
    elif method == "grid":
        kcr, w, crossovers, err = grid_critical_force_gain(device, hm, filt, grid_points)
        src = f"the change of K_f across the bracketing grid interval ({grid_points} log-spaced θ from 1e-4 to π)"
    elif method == "exact":
        res = critical_force_gain(device, filt, hm)
        kcr, w, crossovers, reason = res.critical_force_gain, res.crossover_frequency, res.crossovers, res.reason
        err = EXACT_REL_ERROR
        src = ("every crossover bracketed and refined to full double precision; agrees with the 40-digit "
               "reference to 1e-12 on the benchmark suite")
    else:
        ref = reference_critical_force_gain(device, hm, filt.order if filt else None,
                                            filt.cutoff_hz if filt else None)
        kcr, w = ref.critical_force_gain, ref.crossover_frequency
        crossovers = tuple(ForceCrossover(frequency=a, force_gain=k) for a, k in ref.crossovers)
        err = 10.0 ** (-(REFERENCE_DIGITS - 5))
        src = f"{ref.digits}-digit mpmath residue z-transform and bisection ({ref.evaluations} evaluations)"
    if not math.isfinite(kcr) and reason is None:
        reason = "no phase crossover: every positive force gain is stable"
    return ForceFeedforwardAnalysis(critical_force_gain=kcr, crossover_frequency=w, crossovers=tuple(crossovers),
                                    worst_case_force_gain=worst, human=hm, human_source=source, method=method,
                                    elapsed_ms=(time.perf_counter() - t0) * 1e3, error_estimate=err,
                                    error_source=src, reason=reason)
