"""Simulate one scene on one device, paying only for the effects the scene names.

Method, chosen from the effects (never silently changed afterwards):
  * ``exact-linear-recursion``: only linear effects; the closed loop is one linear
    recursion propagated exactly and without a per-sample Python loop
    (models/simulation/propagate.py);
  * ``exact-sampled-loop``: a sampled nonlinearity (relay, quantization,
    saturation); exact matrices between samples, stepped sample by sample;
  * ``event-integrator``: Coulomb friction, a continuous-time nonlinearity;
    exact affine pieces with located stick/slip events (models/simulation/friction.py).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from models.device import Device
from models.errors import InputError
from models.simulation.friction import FrictionStepper
from models.simulation.oscillation import Verdict, analyse_oscillation, energy_generated
from models.simulation.propagate import linear_outputs
from models.simulation.scene import MAX_SAMPLES_EVENT_INTEGRATOR, MAX_SAMPLES_LINEAR, MAX_SAMPLES_SAMPLED_LOOP, Scene
from models.simulation.scene_poles import MAX_EXACT_STATES, ScenePoles, closed_loop_poles
from models.simulation.sim_loop import (
    LoopSpec,
    Record,
    Stepper,
    closed_loop_matrices,
    feedforward_filter,
    linear_part,
    linear_step,
    run_sampled_loop,
    wall_polynomials,
)
from models.simulation.sim_plant import SceneModelError, build_plant, sample_plant
from models.simulation.verdict import SceneVerdict, decide
from models.velocity_filter import rendering

__all__ = ["Trajectory", "SimulationResult", "simulate", "propagation_method", "sample_count",
           "check_cost", "SceneModelError", "loop_spec", "DIVERGENCE_FACTOR", "scene_poles", "scene_resolution",
           "scene_friction", "scene_stepper"]

#: A run stops as diverged when |x_r| exceeds this factor times its free-motion scale (_scale).
DIVERGENCE_FACTOR = 1e6

_LIMITS = {"exact-linear-recursion": MAX_SAMPLES_LINEAR, "exact-sampled-loop": MAX_SAMPLES_SAMPLED_LOOP,
           "event-integrator": MAX_SAMPLES_EVENT_INTEGRATOR}


@dataclass(frozen=True)
class Trajectory:
    """The downsampled run (SI units)."""

    time: np.ndarray
    motor_position: np.ndarray
    """x_r [m] (the encoder side; the whole device when rigid)."""
    body_position: np.ndarray
    """x_d [m] (equal to x_r when rigid)."""
    force: np.ndarray
    """commanded motor force u[k] [N]."""
    energy_generated: np.ndarray
    """E_gen [J] (models/simulation/oscillation.py)."""


@dataclass(frozen=True)
class SimulationResult:
    effects_simulated: tuple[str, ...]
    not_simulated: tuple[str, ...]
    """device blocks the scene did not name, so they were left out (said, never silent)."""
    method: str
    sample_time: float
    samples: int
    """samples requested (duration / T)."""
    samples_run: int
    """samples actually simulated (fewer when the run diverged)."""
    diverged_at: float | None
    """[s] where the run stopped as diverged, else None."""
    trajectory: Trajectory
    record: Record
    """every sample of the run (not serialised; the relay analysis reads it)."""
    verdict: Verdict
    """the answer (models/simulation/verdict.py): the closed-loop poles decide a linear scene, the trajectory otherwise."""
    judgement: SceneVerdict
    """the measured verdict, the poles and any disagreement behind ``verdict``."""
    energy_generated: float
    """E_gen at the end [J]."""
    energy_generated_max: float
    """largest E_gen over the run [J]."""
    energy_generated_second_half: float
    """E_gen(end) - E_gen(middle) [J]: > 0 means the wall keeps creating energy."""
    elapsed_ms: float


def propagation_method(scene: Scene) -> str:
    eff = scene.effects
    if eff.coulomb_friction is not None:
        return "event-integrator"
    if scene.experiment == "relay" or eff.quantization is not None or eff.saturation is not None:
        return "exact-sampled-loop"
    return "exact-linear-recursion"


def sample_count(device: Device, scene: Scene) -> int:
    return max(1, int(round(scene.duration / device.sample_time)))


def _given_or_device(given: float | None, device_value: float | None, effect: str, parameter: str,
                     device_field: str) -> float:
    """The effect's own ``parameter`` when given, else the device's ``device_field``; refused (SceneModelError
    naming scene.effects.<effect>) when neither is there."""
    if given is not None:
        return given
    if device_value is None:
        raise SceneModelError(f"scene.effects.{effect}", f"names no {parameter} and the device has no "
                              f"{device_field}: give one of the two")
    return device_value


def scene_resolution(device: Device, scene: Scene) -> float | None:
    """q [m] the scene quantises with: its own ``resolution``, else the device's ``encoder_resolution``; None
    when the scene names no quantization.  A quantization named without a resolution on a device without one
    is refused (SceneModelError naming scene.effects.quantization)."""
    eff = scene.effects.quantization
    return None if eff is None else _given_or_device(eff.resolution, device.encoder_resolution, "quantization",
                                                     "resolution", "encoder_resolution")


def scene_friction(device: Device, scene: Scene) -> float | None:
    """f_c [N] of the scene's Coulomb friction: its own ``force``, else the device's ``coulomb_friction``; None
    when the scene names none.  Refused (SceneModelError) when neither gives a force."""
    eff = scene.effects.coulomb_friction
    return None if eff is None else _given_or_device(eff.force, device.coulomb_friction, "coulomb_friction",
                                                     "force", "coulomb_friction")


def scene_stepper(spec: LoopSpec, friction: float | None, x0: np.ndarray) -> Stepper:
    """One sample of the loop's plant: with Coulomb friction ``friction`` [N] the event integrator (started at
    ``x0``), without (None) the exact linear step."""
    if friction is None:
        return linear_step(spec.sampled)
    stepper = FrictionStepper(spec.sampled, friction)
    stepper.reset(x0)
    return stepper


def check_cost(device: Device, scene: Scene) -> None:
    """Raise ValueError naming scene.duration when the run exceeds its method's sample limit, or naming the
    effect when a nonlinear effect has no parameter (scene_resolution, scene_friction)."""
    scene_resolution(device, scene)
    scene_friction(device, scene)
    method = propagation_method(scene)
    n = sample_count(device, scene)
    if n > _LIMITS[method]:
        raise InputError("scene.duration", f"{scene.duration:g} s is {n} samples at T = {device.sample_time:g} s; "
                         f"the limit for method {method} is {_LIMITS[method]} samples")


def _not_simulated(device: Device, scene: Scene) -> tuple[str, ...]:
    eff, out = scene.effects, []
    if device.delay > 0 and eff.delay is None:
        out.append(f"delay: the device's {device.delay:g} s of delay (the scene does not name 'delay')")
    for block, name in (("cable", "cable_mode"), ("human", "human"), ("force_sensor", "force_sensor_filter")):
        if getattr(device, block) is not None and getattr(eff, name) is None:
            out.append(f"{block}: the device's {block} block (the scene does not name '{name}')")
    return tuple(out)


def loop_spec(device: Device, scene: Scene) -> LoopSpec:
    eff = scene.effects
    plant = build_plant(device, eff)
    sampled = sample_plant(plant, device.sample_time, device.delay if eff.delay is not None else 0.0)
    ff = eff.force_feedforward
    wall = None
    c = scene.controller
    if c is not None and ({"mass", "velocity_filter"} & c.model_fields_set):
        try:
            vel = rendering(c.velocity_filter, c.mass, device.sample_time)
        except InputError as exc:
            raise exc.under("scene.controller.") from None
        if not vel.is_default:
            wall = wall_polynomials(c.stiffness, c.damping, c.mass, vel.velocity, device.sample_time)
    return LoopSpec(
        wall=wall,
        sampled=sampled,
        stiffness=scene.controller.stiffness if scene.controller else 0.0,
        damping=scene.controller.damping if scene.controller else 0.0,
        relay_amplitude=scene.relay.amplitude if scene.relay is not None else None,
        ff_gain=ff.gain if ff is not None else 0.0,
        ff_filter=feedforward_filter(ff.cutoff_hz, ff.order, device.sample_time) if ff is not None else None,
        quantization=scene_resolution(device, scene),
        max_force=eff.saturation.max_force if eff.saturation is not None else None,
    )


def _translation_invariant(device: Device, scene: Scene) -> bool:
    """No force depends on where the device is (K = 0, no grasp stiffness): z = 1 is an exact pole."""
    k = scene.controller.stiffness if scene.controller else 0.0
    k_h = device.human.stiffness if (scene.effects.human is not None and device.human is not None) else 0.0
    return k == 0.0 and k_h == 0.0


def scene_poles(device: Device, scene: Scene) -> tuple[ScenePoles | None, str | None]:
    """Closed-loop poles of the scene's linear part (the scene itself when linear); (None, why) when there
    is no linear part (relay) or the loop is too large for dense eigenvalues."""
    if scene.experiment == "relay":
        return None, "a relay loop has no linearisation (its gain is unbounded at y = 0)"
    spec = loop_spec(device, scene)
    if spec.quantization is not None or spec.max_force is not None:
        spec = linear_part(spec)
    a = closed_loop_matrices(spec, np.zeros(spec.sampled.phi.shape[0]), 0.0)[0]
    if not np.all(np.isfinite(a)):
        return None, "the closed-loop matrix is not finite in floating point (extreme parameters)"
    try:
        poles = closed_loop_poles(a, device.sample_time, _translation_invariant(device, scene))
    except (np.linalg.LinAlgError, ValueError) as exc:
        return None, f"the eigenvalue computation failed ({type(exc).__name__})"
    if poles is None:
        return None, (f"the closed loop has {a.shape[0]} states (a delay line of {spec.sampled.d} samples); "
                      f"dense eigenvalues are limited to {MAX_EXACT_STATES} states")
    return poles, None


def _user_force(device: Device, scene: Scene, n: int) -> np.ndarray:
    if scene.push is None:
        return np.zeros(n)
    t = np.arange(n) * device.sample_time
    return np.interp(t, scene.push.times, scene.push.forces, left=0.0)


def _scale(device: Device, scene: Scene, w: np.ndarray) -> float:
    """A bound [m] on how far the device could move in this run without any wall: its start plus
    the free motion under the largest force (F·D²/2m).  A run is diverged beyond 1e6 times this."""
    dur = scene.duration
    force = max(np.max(np.abs(w)) if w.size else 0.0, scene.relay.amplitude if scene.relay else 0.0)
    return max(abs(scene.initial.position), abs(scene.initial.velocity) * dur,
               force * dur * dur / (2 * device.mass), 1e-300)


def _downsample(rec: Record, energy: np.ndarray, t: float, points: int) -> Trajectory:
    n = len(rec.motor_position) - 1
    idx = np.unique(np.round(np.linspace(0, n, min(points, n + 1))).astype(int))
    cmd = np.append(rec.command, rec.command[-1] if len(rec.command) else 0.0)
    return Trajectory(time=idx * t, motor_position=rec.motor_position[idx], body_position=rec.body_position[idx],
                      force=cmd[idx], energy_generated=energy[idx])


def simulate(device: Device, scene: Scene) -> SimulationResult:
    """Run the scene (see the module docstring for the method)."""
    start = time.perf_counter()
    check_cost(device, scene)
    method = propagation_method(scene)
    n = sample_count(device, scene)
    spec = loop_spec(device, scene)
    pl, t = spec.sampled.plant, device.sample_time
    x0 = np.zeros(pl.a.shape[0])
    npos = 2 if scene.effects.cable_mode is not None else 1
    x0[:npos] = scene.initial.position
    x0[npos:2 * npos] = scene.initial.velocity
    w = _user_force(device, scene, n)
    limit = DIVERGENCE_FACTOR * _scale(device, scene, w)
    if method == "exact-linear-recursion":
        a, b_w, out, d_out, z0 = closed_loop_matrices(spec, x0, scene.initial.velocity)
        y = linear_outputs(a, z0, out, n + 1, b=b_w, w=np.append(w, 0.0), d_out=d_out)
        bad = ~(np.abs(y[0]) <= limit)
        run = int(np.argmax(bad)) if bad.any() else n
        rec = Record(y[0, :run + 1], y[1, :run + 1], y[2, :run], y[3, :run], y[4, :run], y[5, :run])
    else:
        step = scene_stepper(spec, scene_friction(device, scene), x0)    # friction ⇔ method event-integrator
        rec, run = run_sampled_loop(spec, x0, scene.initial.velocity, w, n, step, diverge_at=limit)
    diverged = run < n
    energy = energy_generated(rec, spec.stiffness)
    linear = method == "exact-linear-recursion"
    measured = analyse_oscillation(rec.motor_position, t, linear=linear, diverged=diverged)
    poles, note = scene_poles(device, scene)
    judgement = decide(measured, poles, linear, note)
    named = scene.effects.named()
    return SimulationResult(
        effects_simulated=("zoh", "sampling") + named + (("relay",) if scene.experiment == "relay" else ()),
        not_simulated=_not_simulated(device, scene), method=method, sample_time=t, samples=n, samples_run=run,
        diverged_at=run * t if diverged else None,
        trajectory=_downsample(rec, energy, t, scene.output_points), record=rec, verdict=judgement.verdict,
        judgement=judgement,
        energy_generated=float(energy[-1]), energy_generated_max=float(np.max(energy)),
        energy_generated_second_half=float(energy[-1] - energy[len(energy) // 2]),
        elapsed_ms=1e3 * (time.perf_counter() - start))
