"""The relay experiment as a lab runs it (chapter §4.4, Fig. 18, Table 4), and what it can read.

A relay loop on a sampled device admits several periodic cycles and the start
decides which one appears (FIELD-NOTES.md).  So the answer is not one number:

  * ``analyse_relay_run`` reads a simulated run like a lab: the switching pattern
    of the settled half, its frequency and first harmonics, K_u = |U₁|/|Y₁|;
    when the pattern repeats it solves that pattern's exact periodic motion
    (optim/relay/relay_cycles.py) and reports how far the simulation is from it; when
    it does not repeat it says so and gives the spread of the per-cycle K_u;
  * ``relay_experiment`` adds the exact analysis: every symmetric cycle the loop
    admits, the phase crossover (optim.stability.margins) the settled cycle sits nearest,
    and K_u's error against the exact K_cr;
  * ``relay_rung`` is the ``experiment`` rung of the accuracy ladder: the K_u a
    lab would read from several starts, with its spread.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from models.device import Device
from models.simulation.scene import Scene
from models.simulation.simulate import SimulationResult, loop_spec, simulate
from optim.errors import InputError
from optim.relay.relay_cycles import PeriodicSolution, pattern_solution, relay_loop, symmetric_cycles
from optim.stability.margins import CriticalStiffness, Crossover, critical_stiffness

__all__ = ["SettledCycle", "RelayReport", "RelayRung", "analyse_relay_run", "relay_experiment", "relay_rung",
           "analysis_device", "MAX_PATTERN", "MAX_HALF_PERIOD_SEARCH"]

#: Longest repeating switching pattern looked for [half periods].
MAX_PATTERN = 12
#: Symmetric cycles are searched up to this half period [samples] at most.
MAX_HALF_PERIOD_SEARCH = 2000
_MIN_SETTLED = 8


@dataclass(frozen=True)
class SettledCycle:
    """The settled relay oscillation of one run."""

    repeats: bool
    """the switching pattern repeats exactly over the settled window."""
    pattern: tuple[int, ...] | None
    """half-period lengths [samples] of the repeating pattern, starting with a +a half."""
    symmetric: bool
    """a repeating pattern of one half period (N, N, …)."""
    half_periods: tuple[int, ...]
    """the settled half periods observed [samples] (the last ones, in order)."""
    half_period_min: int
    half_period_max: int
    frequency: float
    """ω [rad/s] from the mean full period of the settled window."""
    force_amplitude: float
    """|U₁| [N], first harmonic of the commanded force."""
    position_amplitude: float
    """|Y₁| [m], first harmonic of the measured position."""
    ultimate_gain: float
    """K_u = |U₁|/|Y₁| [N/m]."""
    ultimate_gain_min: float
    """smallest per-cycle K_u in the settled window [N/m] (each full cycle read on its own)."""
    ultimate_gain_max: float
    mean_position: float
    """[m] centre of the settled oscillation (a relay leaves the integrator's offset free)."""
    exact: PeriodicSolution | None
    """the exact periodic solution of the pattern, when it repeats."""
    force_amplitude_error: float | None
    """relative difference of |U₁| simulated vs exact."""
    position_amplitude_error: float | None
    frequency_error: float | None


@dataclass(frozen=True)
class RelayReport:
    amplitude: float
    """a, relay force [N]."""
    start_position: float
    start_velocity: float
    settled: SettledCycle | None
    reason: str | None
    """why there is no settled cycle (too few switches), else None."""
    critical_stiffness: CriticalStiffness
    """exact K_cr of the loop the relay closes (same device, delay and cable choice)."""
    nearest_crossover: Crossover | None
    """the phase crossover the settled cycle's frequency sits nearest (log distance)."""
    ultimate_gain_error: float | None
    """(K_u - K_cr)/K_cr."""
    cycles: tuple[PeriodicSolution, ...]
    """every symmetric cycle N = 1 … searched_half_periods, with ``admissible``."""
    searched_half_periods: int
    admissible_gain_range: tuple[float, float] | None
    """[N/m] smallest and largest K_u over the admissible symmetric cycles."""
    notes: tuple[str, ...]


@dataclass(frozen=True)
class RelayRung:
    """The ``experiment`` rung of the accuracy ladder."""

    ultimate_gains: tuple[float, ...]
    """K_u [N/m] read from each start."""
    frequencies: tuple[float, ...]
    """ω [rad/s] of each start's settled cycle."""
    starts: tuple[float, ...]
    """initial positions [m]."""
    repeats: tuple[bool, ...]
    spread: tuple[float, float]
    """(min, max) K_u over the starts [N/m]."""
    critical_stiffness: float
    """exact K_cr [N/m] beside it."""
    admissible_gain_range: tuple[float, float] | None
    method: str
    elapsed: float
    """[s] wall time of the whole rung."""


def _switches(cmd: np.ndarray) -> np.ndarray:
    return np.nonzero(cmd[1:] != cmd[:-1])[0] + 1


def _period_of(seq: np.ndarray) -> int | None:
    for p in range(1, MAX_PATTERN + 1):
        m = max(4 * p, _MIN_SETTLED)
        if len(seq) >= m + p and np.all(seq[-m:] == seq[-m - p:-p]):
            return p
    return None


def _harm(seq: np.ndarray) -> complex:
    k = np.arange(len(seq))
    return complex(np.sum(seq * np.exp(-2j * math.pi * k / len(seq)))) * 2.0 / len(seq)


def _lab_estimate(u: np.ndarray, y: np.ndarray, t: float) -> tuple[float, float, float]:
    """(ω, |U(ω)|, |Y(ω)|) as the chapter's lab does (§4.4): the frequency of the largest peak of
    the position's spectrum (Hann window, 4× zero padding, parabolic peak), then both signals'
    windowed Fourier amplitudes at that frequency (their ratio is the empirical transfer there)."""
    n = len(y)
    win = np.hanning(n)
    yc = (y - y.mean()) * win
    nfft = 1 << int(math.ceil(math.log2(4 * n)))
    spec = np.abs(np.fft.rfft(yc, nfft))
    i = int(np.argmax(spec[1:])) + 1
    shift = 0.0
    if i < len(spec) - 1 and spec[i - 1] > 0 and spec[i + 1] > 0:
        a, b, c = np.log(spec[i - 1:i + 2])
        shift = 0.5 * (a - c) / (a - 2 * b + c) if a - 2 * b + c != 0 else 0.0
    theta = 2 * math.pi * (i + shift) / nfft
    e = np.exp(-1j * theta * np.arange(n)) * win
    scale = 2.0 / win.sum()
    return (theta / t, abs(complex(np.sum((u - u.mean()) * e))) * scale,
            abs(complex(np.sum((y - y.mean()) * e))) * scale)


def _rel(a: float, b: float) -> float:
    return abs(a - b) / abs(b)


def analyse_relay_run(result: SimulationResult, loop, amplitude: float) -> tuple[SettledCycle | None, str | None]:
    """Read the settled cycle of a simulated relay run (module docstring)."""
    rec, t = result.record, result.sample_time
    cmd, y = rec.command, rec.motor_position[:-1]
    sw = _switches(cmd)
    sw = sw[sw >= len(cmd) // 2]                       # the settled half of the run
    if len(sw) < _MIN_SETTLED + 1:
        return None, f"only {len(sw)} relay switches in the settled half of the run; run longer"
    half = np.diff(sw)
    ups = [int(s) for s in sw if cmd[s] > 0]
    if len(ups) < 3:
        return None, "fewer than three relay cycles in the settled half of the run; run longer"
    win_a, win_b = ups[0], ups[-1]
    freq, u1, y1 = _lab_estimate(cmd[win_a:win_b], y[win_a:win_b], t)
    quarter = (win_b - win_a) // 4
    gains = [_lab_estimate(cmd[win_a + i * quarter:win_a + (i + 1) * quarter],
                           y[win_a + i * quarter:win_a + (i + 1) * quarter], t)[1:] for i in range(4)]
    gains = [a / b for a, b in gains]
    p = _period_of(half)
    exact, pattern = None, None
    errs: tuple[float | None, float | None, float | None] = (None, None, None)
    if p is not None:
        last = len(half) - p                         # rotate so the pattern starts with a +a half
        for start in range(last, -1, -1):
            if cmd[sw[start]] > 0:
                break
        pattern = tuple(int(v) for v in half[start:start + p])
        exact = pattern_solution(loop, pattern, amplitude)
        period = exact.period_samples
        s0 = int(sw[start])
        while s0 + period > len(cmd):
            s0 -= period
        if s0 >= len(cmd) // 2:
            u1, y1 = abs(_harm(cmd[s0:s0 + period])), abs(_harm(y[s0:s0 + period]))
            freq = 2 * math.pi / (period * t)
            errs = (_rel(u1, exact.force_amplitude), _rel(y1, exact.position_amplitude),
                    _rel(freq, exact.frequency))
            win_a, win_b = s0, s0 + period
            gains = [u1 / y1]
    return SettledCycle(
        repeats=p is not None, pattern=pattern, symmetric=p == 1, half_periods=tuple(int(v) for v in half[-40:]),
        half_period_min=int(half.min()), half_period_max=int(half.max()), frequency=freq,
        force_amplitude=u1, position_amplitude=y1, ultimate_gain=u1 / y1,
        ultimate_gain_min=float(min(gains)) if gains else u1 / y1,
        ultimate_gain_max=float(max(gains)) if gains else u1 / y1,
        mean_position=float(np.mean(y[win_a:win_b])), exact=exact,
        force_amplitude_error=errs[0], position_amplitude_error=errs[1], frequency_error=errs[2]), None


def analysis_device(device: Device, scene: Scene) -> Device:
    """The device the exact analysis sees for this scene: cable and delay only when the scene names them."""
    upd: dict = {}
    if scene.effects.cable_mode is None:
        return device.rigid().model_copy(update={"delay": device.delay if scene.effects.delay else 0.0})
    if scene.effects.delay is None:
        upd["delay"] = 0.0
    return device.model_copy(update=upd)


def _search_limit(crit: CriticalStiffness, t: float) -> int:
    freqs = [c.frequency for c in crit.crossovers if c.frequency > 0]
    if not freqs:
        return 400
    return int(min(MAX_HALF_PERIOD_SEARCH, max(200, math.ceil(4 * math.pi / (min(freqs) * t)))))


def relay_experiment(device: Device, scene: Scene, result: SimulationResult | None = None) -> RelayReport:
    """Simulate (unless given) and analyse a relay scene."""
    if scene.experiment != "relay" or scene.relay is None:
        raise InputError("scene.experiment", "relay_experiment needs a relay scene")
    result = result if result is not None else simulate(device, scene)
    amplitude = scene.relay.amplitude
    loop = relay_loop(loop_spec(device, scene).sampled)
    settled, reason = analyse_relay_run(result, loop, amplitude)
    crit = critical_stiffness(analysis_device(device, scene))
    n_max = _search_limit(crit, device.sample_time)
    cycles = tuple(symmetric_cycles(loop, amplitude, n_max))
    adm = [c.ultimate_gain for c in cycles if c.admissible]
    nearest, err = None, None
    if settled is not None and crit.crossovers:
        nearest = min(crit.crossovers, key=lambda c: abs(math.log(settled.frequency / c.frequency)))
        if math.isfinite(crit.critical_stiffness) and crit.critical_stiffness > 0:
            err = (settled.ultimate_gain - crit.critical_stiffness) / crit.critical_stiffness
    notes = []
    eff = scene.effects
    for name in ("human", "force_sensor_filter", "force_feedforward", "quantization", "saturation",
                 "coulomb_friction"):
        if getattr(eff, name) is not None:
            notes.append(f"{name} is simulated but not in the exact K_cr nor in the exact cycles "
                         "(they are for the linear plant the relay closes)")
    return RelayReport(amplitude=amplitude, start_position=scene.initial.position,
                       start_velocity=scene.initial.velocity, settled=settled, reason=reason,
                       critical_stiffness=crit, nearest_crossover=nearest, ultimate_gain_error=err,
                       cycles=cycles, searched_half_periods=n_max,
                       admissible_gain_range=(min(adm), max(adm)) if adm else None, notes=tuple(notes))


def relay_rung(device: Device, amplitude: float = 1.0, starts: tuple[float, ...] = (1e-6, 1e-4, 3e-3),
               duration: float = 20.0) -> RelayRung:
    """K_u from a relay run per start (the device's cable and delay included when it has them)."""
    t0 = time.perf_counter()
    effects: dict = {}
    if device.cable is not None:
        effects["cable_mode"] = {}
    if device.delay > 0:
        effects["delay"] = {}
    gains, freqs, reps, rng, kcr = [], [], [], None, math.nan
    for x0 in starts:
        scene = Scene(experiment="relay", duration=duration, relay={"amplitude": amplitude},
                      initial={"position": x0}, effects=effects)
        rep = relay_experiment(device, scene)
        if rep.settled is None:
            raise RuntimeError(f"relay_rung: no settled cycle from start {x0:g} m: {rep.reason}")
        gains.append(rep.settled.ultimate_gain)
        freqs.append(rep.settled.frequency)
        reps.append(rep.settled.repeats)
        rng, kcr = rep.admissible_gain_range, rep.critical_stiffness.critical_stiffness
    return RelayRung(ultimate_gains=tuple(gains), frequencies=tuple(freqs), starts=tuple(starts),
                     repeats=tuple(reps), spread=(min(gains), max(gains)), critical_stiffness=kcr,
                     admissible_gain_range=rng, method="experiment", elapsed=time.perf_counter() - t0)
