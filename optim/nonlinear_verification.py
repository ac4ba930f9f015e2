"""Issue 31's checks by simulation: the energy audit of a push-and-release and the measured limit cycle.

Energy audit.  The quantised, Coulomb-damped wall is simulated exactly (models/simulation: the ZOH
plant between samples, Coulomb friction by located stick/slip events, the encoder's q·round(x/q)),
recording the full state after every sample.  Two numbers, both exact functions of that record:

  * the port balance E_net(t) = S(t) − S(0) − Σ F_h·Δx_d, with S = Σ ½m_i v_i² + ½K x_r² (+ ½k_c(x_r − x_d)²
    for a cable) the energy an ideal continuous wall would store.  The user's force is held over each
    sample, so Σ F_h·Δx_d is the user's exact work.  A passive display keeps E_net ≤ 0 (Abbott & Okamura's
    definition with this storage); a wall that grows (the sampling mode, K > 2b/T) drives it positive;
  * the wall's energy while the user holds still, E_hold = E_gen(end of hold) − E_gen(¾ of the hold)
    (models/simulation/oscillation.py: the motor's exact work minus the ideal spring's).  A passive wall
    stops the device (friction sticks it) and E_hold is exactly 0: no velocity, no work.  A wall that
    chatters at the quantisation scale (K > 2f_c/q) keeps paying the friction's loss: E_hold > 0.

net_energy = E_hold when the wall chatters (the device within a few counts, E_hold sustained), else
max_t E_net.  Its error bound is the rounding of the sums (8·eps per term
over every term's magnitude) and of the stored energy; the trajectory itself is exact to the event
location's tolerance (1e-15·T in time).

Measured cycle: a release from ``initial`` simulated for ``duration``; over its last quarter, the half
peak-to-peak amplitude of x_r and the frequency from the mean spacing of its crossings of the mean.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from models.device import Device
from models.simulation.friction import FrictionEventLimit
from models.simulation.oscillation import energy_generated
from models.simulation.scene import Scene
from models.simulation.sim_loop import run_sampled_loop
from models.simulation.simulate import loop_spec, scene_friction, scene_poles, scene_stepper

__all__ = ["EnergyAudit", "MeasuredCycle", "NonlinearVerification", "energy_audit", "measure_cycle", "nonlinear_effects",
           "verify_nonlinear", "probe_forces", "probe_hold", "release_start", "linear_time_constant",
           "release_duration", "AMPLITUDE_RTOL", "FREQUENCY_RTOL",
           "CYCLE_MIN_COUNTS", "CHATTER_COUNTS", "GROWTH_RATIO", "UNSTABLE_RELEASE_COUNTS",
           "UNSTABLE_RELEASE_THRESHOLDS"]

_EPS = float(np.finfo(float).eps)
#: A sustained motion counts as a cycle when its half peak-to-peak is at least this many encoder counts
#: (Abbott & Okamura's tactile chatter right above 2f_c/q moves ~(Kq/2 − f_c)·T²/m per sample, far below a
#: count: it is reported as chatter by the audit, not as a describing-function cycle).
CYCLE_MIN_COUNTS = 0.25
#: A release whose last quarter swings this much wider than the quarter before is growing, not cycling.
GROWTH_RATIO = 1.02
#: The audit's free motion grows when its last quarter swings wider than the quarter before by this factor.
AUDIT_GROWTH = 1.01
#: Motion within this many counts over the hold's last quarter is quantisation-scale chatter, not growth.
CHATTER_COUNTS = 4.0


def nonlinear_effects(device: Device) -> dict:
    """The scene effects that simulate this device whole: its encoder, friction, delay and cable."""
    eff: dict = {}
    if device.encoder_resolution is not None:
        eff["quantization"] = {}
    if device.coulomb_friction:
        eff["coulomb_friction"] = {}
    if device.delay > 0:
        eff["delay"] = {}
    if device.cable is not None:
        eff["cable_mode"] = {}
    return eff


def _run(device: Device, scene: Scene, w: np.ndarray, x0: np.ndarray, v0: float):
    """The scene's loop stepped sample by sample; returns the record and every state x[k], k = 0..n."""
    spec = loop_spec(device, scene)
    stepper = scene_stepper(spec, scene_friction(device, scene) or None, x0)    # no friction force: linear
    states = [np.array(x0, dtype=float)]

    def step(x, ua, ub, wk):
        xn, mid = stepper(x, ua, ub, wk)
        states.append(xn)
        return xn, mid
    rec, run = run_sampled_loop(spec, x0, v0, w, len(w), step, diverge_at=1e6)
    return spec, rec, np.array(states[:run + 1])


@dataclass(frozen=True)
class EnergyAudit:
    net_energy: float
    """[J] the wall's net energy: E_hold when the audit found chatter, else max_t E_net (module docstring);
    ≤ 0 for a passive display."""
    port_balance_max: float
    """[J] max_t E_net(t)."""
    hold_energy: float
    """[J] E_hold: the wall's energy over the last quarter of the hold."""
    error_bound: float
    """[J] bound on the rounding error of net_energy."""
    active: bool
    """the audit found the wall active (mode ≠ none)."""
    mode: Literal["none", "instability", "chatter"]
    """instability: E_net grew (a sampling-mode growth); chatter: the device kept moving within a few counts
    while the user held still; none: passive on this push."""
    hold_motion_counts: float | None
    """peak-to-peak of x_r over the second half of the hold [encoder counts] (None without an encoder)."""
    push_force: float
    """[N] the held user force."""
    samples: int


def energy_audit(device: Device, stiffness: float, damping: float, push_force: float, *, ramp: float = 0.2,
                 hold: float = 2.0, free: float = 1.0, wall: dict | None = None) -> EnergyAudit:
    """Push (ramp to ``push_force`` [N] over ``ramp`` [s]), hold for ``hold`` [s], release (ramp down over
    2 samples), then ``free`` [s] without force; the audit of the module docstring."""
    t = device.sample_time
    t1, t2 = ramp, ramp + hold
    times = [0.0, t1, t2, t2 + 2 * t]
    forces = [0.0, push_force, push_force, 0.0]
    duration = t2 + 2 * t + free
    scene = Scene.model_validate(dict(experiment="push", duration=duration,
                                      controller=_controller(stiffness, damping, wall),
                                      push={"times": times, "forces": forces}, effects=nonlinear_effects(device),
                                      output_points=2))
    n = int(round(duration / t))
    w = np.interp(np.arange(n) * t, times, forces, left=0.0)
    spec, rec, x = _run(device, scene, w, np.zeros(spec_size(device)), 0.0)
    pl = spec.sampled.plant
    m = len(x) - 1
    xr, xd = x[:, pl.motor_position], x[:, pl.body_position]
    if device.cable is not None:
        c = device.cable
        kinetic = 0.5 * c.motor_mass * x[:, pl.motor_velocity] ** 2 + 0.5 * c.body_mass * x[:, 3] ** 2
        stored = kinetic + 0.5 * c.stiffness * (xr - xd) ** 2 + 0.5 * stiffness * xr ** 2
    else:
        stored = 0.5 * device.mass * x[:, pl.motor_velocity] ** 2 + 0.5 * stiffness * xr ** 2
    work = w[:m] * np.diff(xd)
    user = np.concatenate([[0.0], np.cumsum(work)])
    e_net = stored - stored[0] - user
    e_gen = energy_generated(rec, stiffness)
    k = [min(int(round((t1 + hold * f) / t)), m) for f in (0.5, 0.75, 1.0)]
    last, before = float(e_gen[k[2]] - e_gen[k[1]]), float(e_gen[k[1]] - e_gen[k[0]])
    force_work = np.abs(rec.applied_first) * np.abs(rec.motor_position_mid - rec.motor_position[:-1]) + \
        np.abs(rec.applied_second) * np.abs(rec.motor_position[1:] - rec.motor_position_mid)
    bound = 8 * _EPS * (m * float(np.max(np.abs(stored))) + float(np.sum(np.abs(work)))
                        + float(np.sum(force_work)) + 0.5 * stiffness * float(np.max(xr ** 2)))
    port = float(np.max(e_net))
    q = device.encoder_resolution
    motion = float(np.ptp(xr[k[1]:k[2] + 1])) if k[2] > k[1] else 0.0
    counts = motion / q if q is not None else None
    confined = counts is not None and counts <= CHATTER_COUNTS and m == n
    # chatter: the wall keeps paying friction and damping over the hold's last quarter as much as over the
    # quarter before (a decaying transient's share shrinks geometrically), the device within a few counts
    chatter = confined and last > bound and last >= 0.25 * before
    # instability: the run diverged, or the free motion after the release swings wider in its last quarter
    # than in the quarter before, beyond the quantisation scale (growth, not chatter)
    kf = [min(int(round((t2 + 2 * t + free * f) / t)), m) for f in (0.5, 0.75, 1.0)]
    swing_late, swing_early = float(np.ptp(xr[kf[1]:kf[2] + 1])), float(np.ptp(xr[kf[0]:kf[1] + 1]))
    scale = CHATTER_COUNTS * q if q is not None else 0.0
    instability = m < n or (swing_late > max(AUDIT_GROWTH * swing_early, scale) and port > bound)
    mode: Literal["none", "instability", "chatter"] = \
        "instability" if instability else "chatter" if chatter else "none"
    net = last if mode == "chatter" else port
    return EnergyAudit(net, port, last, bound, instability or chatter, mode, counts, push_force, m)


def _controller(stiffness: float, damping: float, wall: dict | None) -> dict:
    """The scene's controller: K, B and the request's velocity filter and virtual mass (``wall``)."""
    return {"stiffness": stiffness, "damping": damping, **(wall or {})}


def spec_size(device: Device) -> int:
    return 4 if device.cable is not None else 2


@dataclass(frozen=True)
class MeasuredCycle:
    state: Literal["settled", "cycle", "growing", "decaying"]
    """settled: the device came to rest (or moves less than CYCLE_MIN_COUNTS); cycle: a sustained oscillation
    of steady amplitude; growing: |x_r| left 1e6 m, or the last quarter's amplitude exceeds the quarter
    before's by more than GROWTH_RATIO; decaying: narrower by more than that (a transient still dying out:
    the run was too short to tell)."""
    amplitude: float
    """[m] half peak-to-peak of x_r over the last quarter."""
    frequency_hz: float | None
    """[Hz] from the crossings of the mean over the last quarter (None when fewer than two)."""
    samples: int


def measure_cycle(device: Device, stiffness: float, damping: float, initial: float, duration: float,
                  wall: dict | None = None) -> MeasuredCycle:
    """Release the wall from ``initial`` [m] and measure what it settles into (module docstring)."""
    t = device.sample_time
    scene = Scene.model_validate(dict(experiment="release", duration=duration,
                                      controller=_controller(stiffness, damping, wall),
                                      initial={"position": initial}, effects=nonlinear_effects(device),
                                      output_points=2))
    n = int(round(duration / t))
    x0 = np.zeros(spec_size(device))
    x0[:2 if device.cable is not None else 1] = initial
    _, rec, _ = _run(device, scene, np.zeros(n), x0, 0.0)
    xr = rec.motor_position
    if len(xr) - 1 < n:
        return MeasuredCycle("growing", math.inf, None, len(xr) - 1)
    tail = xr[-max(n // 4, 8):]
    amp = 0.5 * float(np.ptp(tail))
    early = 0.5 * float(np.ptp(xr[-2 * len(tail):-len(tail)]))
    q = device.encoder_resolution
    floor = CYCLE_MIN_COUNTS * q if q is not None else 1e-9 * max(abs(initial), 1e-300)
    if amp < floor:
        return MeasuredCycle("settled", amp, None, n)
    if amp > GROWTH_RATIO * early:
        return MeasuredCycle("growing", amp, None, n)
    if amp * GROWTH_RATIO < early:
        return MeasuredCycle("decaying", amp, None, n)
    centred = tail - 0.5 * (tail.max() + tail.min())
    sign = np.signbit(centred)
    ups = np.nonzero(~sign[1:] & sign[:-1])[0]
    freq = None if len(ups) < 2 else (len(ups) - 1) / ((ups[-1] - ups[0]) * t)
    return MeasuredCycle("cycle", amp, freq, n)


#: Relative tolerance on the describing function's amplitude and frequency against a long simulation: the
#: spread measured on random walls (docs/quantisation.md, bench/bench_quantisation.py).
AMPLITUDE_RTOL = 0.6
FREQUENCY_RTOL = 0.3


@dataclass(frozen=True)
class NonlinearVerification:
    verdict: Literal["confirmed", "contradicted", "not_checkable"]
    reason: str
    chatter_probe: EnergyAudit | None
    """push held halfway between two encoder levels (or at 50 f_c without an encoder); None when the simulator
    refused."""
    instability_probe: EnergyAudit | None
    """a deep push released in two samples."""
    measured: MeasuredCycle | None
    release_from: float
    """[m] the release's start."""
    predicted_amplitude: float | None
    predicted_frequency_hz: float | None


def probe_forces(device: Device, stiffness: float, threshold: float | None) -> tuple[float, float]:
    """[N] the chatter probe's held force (halfway between levels 50 and 51) and the instability probe's (10×
    the predicted threshold, else 500 counts, else 1000 f_c, deep)."""
    q, f_c = device.encoder_resolution, device.coulomb_friction or 0.0
    soft = stiffness * q * 50.5 if q is not None else 50 * f_c
    depth = 10 * threshold if threshold is not None else 500 * q if q is not None else 1e3 * f_c / stiffness
    return soft, stiffness * depth


def linear_time_constant(device: Device, stiffness: float, damping: float, wall: dict | None = None) -> float:
    """[s] 1/|γ| of the dominant closed-loop pole of the wall without its encoder and friction (how fast a
    transient dies out or grows); inf when the poles cannot be had."""
    eff = {k: v for k, v in nonlinear_effects(device).items() if k in ("delay", "cable_mode")}
    scene = Scene.model_validate(dict(experiment="release", duration=1.0,
                                      controller=_controller(stiffness, damping, wall), effects=eff,
                                      output_points=2))
    poles, _ = scene_poles(device, scene)
    if poles is None or poles.dominant_modulus <= 0:
        return math.inf
    rate = abs(math.log(poles.dominant_modulus)) / device.sample_time
    return math.inf if rate == 0 else 1.0 / rate


def release_duration(device: Device, stiffness: float, damping: float, lo: float = 2.0, hi: float = 5.0,
                     wall: dict | None = None) -> float:
    """[s] a release long enough for ten linear time constants, within [lo, hi]."""
    return min(max(lo, 10 * linear_time_constant(device, stiffness, damping, wall)), hi)


def probe_hold(device: Device) -> float:
    """[s] how long the chatter probe holds: twenty free-motion time constants m/b (the push's transient must have
    died out before the hold's last quarter is read), within 1-5 s."""
    return min(max(1.0, 20 * device.mass / max(device.damping, 1e-300)), 5.0)


#: A wall predicted unstable is released from at least this many counts (or f_c/K without an encoder): the regime
#: says large motions grow (K > K_cr); the threshold below which friction or the dead band holds a motion is the
#: describing function's estimate, checked apart (docs/quantisation_runs.md), not the regime's claim.
UNSTABLE_RELEASE_COUNTS = 200.0
#: … and from this many times the threshold (the DF's friction damping 4f_c/(πAω) there is 1/30 of its value at the
#: threshold: the loop is then within a few percent of the linear one)
UNSTABLE_RELEASE_THRESHOLDS = 30.0


def release_start(device: Device, stiffness: float, cycle) -> float:
    """[m] where the measured release starts: for a wall with a growth threshold (K > K_cr: the regime says large
    motions grow) the larger of 30× the threshold and UNSTABLE_RELEASE_COUNTS counts; else 1.5× a predicted
    cycle; else 20 counts (or 20 f_c/K without an encoder)."""
    q = device.encoder_resolution
    scale = q if q is not None else (device.coulomb_friction or 0.0) / stiffness
    if cycle.threshold_amplitude is not None:
        return max(UNSTABLE_RELEASE_THRESHOLDS * cycle.threshold_amplitude, UNSTABLE_RELEASE_COUNTS * scale)
    if cycle.exists:
        return 1.5 * cycle.amplitude
    return 20 * scale


def verify_nonlinear(device: Device, stiffness: float, damping: float, analysis, duration: float | None = None,
                     wall: dict | None = None) -> NonlinearVerification:
    """The audit and the measured cycle beside ``analysis`` (optim.stability.nonlinear.NonlinearAnalysis);
    ``wall``: the controller's ``velocity_filter`` and ``mass`` as the request gave them (simulated with the wall)."""
    cycle = analysis.limit_cycle
    soft_f, hard_f = probe_forces(device, stiffness, cycle.threshold_amplitude)
    start = release_start(device, stiffness, cycle)
    duration = duration if duration is not None else release_duration(device, stiffness, damping, wall=wall)
    try:
        soft = energy_audit(device, stiffness, damping, soft_f, ramp=0.2, hold=probe_hold(device), free=0.2, wall=wall)
        hard = energy_audit(device, stiffness, damping, hard_f, ramp=0.02, hold=0.3, free=4.0, wall=wall)
        measured = measure_cycle(device, stiffness, damping, start, duration, wall)
    except FrictionEventLimit as exc:
        return NonlinearVerification("not_checkable", f"the simulator refused: {exc}", None, None, None, start,
                                     cycle.amplitude, cycle.frequency_hz)
    args = (soft, hard, measured, start, cycle.amplitude, cycle.frequency_hz)
    regime = analysis.regime
    if regime == "passive" and (soft.active or hard.active):
        probe = soft if soft.active else hard
        return NonlinearVerification("contradicted", f"passive predicted, but the audit found {probe.mode} "
                                     f"(net energy {probe.net_energy:.3g} J > bound {probe.error_bound:.2g} J)", *args)
    if measured.state == "decaying":
        return NonlinearVerification("not_checkable", f"the release from {start:.3g} m was still decaying after "
                                     f"{duration:g} s", *args)
    if regime == "undetermined":
        return NonlinearVerification("not_checkable", f"the regime is undetermined (the analysis makes no call to "
                                     f"check); the release from {start:.3g} m is {measured.state}", *args)
    expected = {"limit_cycle": "cycle", "unstable": "growing"}.get(regime, "settled")
    if measured.state != expected:
        return NonlinearVerification("contradicted", f"regime {regime} predicts the release from {start:.3g} m "
                                     f"to be {expected}; the simulation shows {measured.state}", *args)
    if expected == "cycle":
        a_ok = abs(measured.amplitude / cycle.amplitude - 1) <= AMPLITUDE_RTOL
        f_ok = measured.frequency_hz is not None and cycle.frequency_hz is not None and \
            abs(measured.frequency_hz / cycle.frequency_hz - 1) <= FREQUENCY_RTOL
        if not (a_ok and f_ok):
            return NonlinearVerification("contradicted", f"cycle measured at {measured.amplitude:.3g} m, "
                                         f"{measured.frequency_hz} Hz; predicted {cycle.amplitude:.3g} m, "
                                         f"{cycle.frequency_hz:.3g} Hz (tolerances {AMPLITUDE_RTOL:g}, "
                                         f"{FREQUENCY_RTOL:g} relative)", *args)
    return NonlinearVerification("confirmed", f"the release from {start:.3g} m is {measured.state} as predicted"
                                 + ("" if regime != "passive" else "; the audit found no active mode"), *args)
