"""What a simulated scene is: the experiment, the controller and the effects it names (SI units).

A scene pays only for what it names: the zero-order hold and the sampling are
always simulated; every other effect (`delay`, `cable_mode`, `human`,
`quantization`, `coulomb_friction`, `saturation`, `force_sensor_filter`,
`force_feedforward`) is simulated only when it appears in ``effects``.  Effects
that take their parameters from the device (delay, cable, human, force sensor)
are plain markers ``{}``; the device must then carry that block.
"""

from __future__ import annotations

import math
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from models.errors import InputError
from models.velocity_filter import MAX_VIRTUAL_MASS, VelocityFilter

__all__ = [
    "EFFECT_NAMES", "LINEAR_EFFECTS", "SAMPLED_NONLINEAR_EFFECTS", "CONTINUOUS_NONLINEAR_EFFECTS",
    "MAX_SAMPLES_LINEAR", "MAX_SAMPLES_SAMPLED_LOOP", "MAX_SAMPLES_EVENT_INTEGRATOR", "MAX_OUTPUT_POINTS",
    "MAX_PUSH_POINTS", "WallController", "InitialState", "PushProfile", "RelaySpec", "Quantization",
    "CoulombFriction", "Saturation", "ForceFeedforward", "Marker", "Effects", "Scene",
]

_STRICT = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)

#: Cost limits (samples of simulated time, duration / sample_time), one per propagation method.
#: The exact linear recursion costs ~0.1-0.3 µs per sample (bench_simulate.md), the
#: per-sample loop used by sampled nonlinearities ~5-10 µs, the event integrator for
#: Coulomb friction ~30-100 µs: each limit keeps one request to about a second.
MAX_SAMPLES_LINEAR = 2_000_000
MAX_SAMPLES_SAMPLED_LOOP = 200_000
MAX_SAMPLES_EVENT_INTEGRATOR = 20_000
#: The downsampled trajectory in the answer has at most this many points.
MAX_OUTPUT_POINTS = 5000
MAX_PUSH_POINTS = 10_000

LINEAR_EFFECTS = ("delay", "cable_mode", "human", "force_sensor_filter", "force_feedforward")
SAMPLED_NONLINEAR_EFFECTS = ("quantization", "saturation")
CONTINUOUS_NONLINEAR_EFFECTS = ("coulomb_friction",)
EFFECT_NAMES = ("zoh", "sampling") + LINEAR_EFFECTS + SAMPLED_NONLINEAR_EFFECTS + CONTINUOUS_NONLINEAR_EFFECTS

_BIG = 1e12


class WallController(BaseModel):
    """Bilateral virtual wall C(z) = K + B·V(z) + M·A(z) at position 0 (force −C·x); today's C(z) = K + B(1 − z⁻¹)/T
    without mass and velocity_filter (ARCHITECTURE.md, "The rendered virtual environment")."""

    model_config = _STRICT
    stiffness: float = Field(ge=0, le=_BIG, description="K, virtual stiffness [N/m]")
    damping: float = Field(default=0.0, ge=0, le=_BIG, description="B, virtual damping [N·s/m]")
    mass: float = Field(default=0.0, ge=-MAX_VIRTUAL_MASS, le=MAX_VIRTUAL_MASS,
                        description="M, virtual mass [kg] rendered as M·A(z), A = V·(1 − z⁻¹)/T; negative compensates "
                                    "inertia")
    velocity_filter: VelocityFilter | None = Field(default=None, description="V(z), the velocity the damper sees; "
                                                                             "null: the backward difference")


class InitialState(BaseModel):
    """Start of the device: position of every mass (penetration into the wall, positive inwards) and velocity."""

    model_config = _STRICT
    position: float = Field(default=0.0, ge=-1e3, le=1e3, description="initial position [m]")
    velocity: float = Field(default=0.0, ge=-1e6, le=1e6, description="initial velocity [m/s]")


class PushProfile(BaseModel):
    """The user's force F_h(t): piecewise linear through (times, forces), constant after the last point.

    The simulator applies it as a staircase held over each sample period (its value
    at the start of the period), like the motor force; that staircase is then
    propagated exactly.
    """

    model_config = _STRICT
    times: list[float] = Field(min_length=1, max_length=MAX_PUSH_POINTS,
                               description="instants [s], strictly increasing, ≥ 0")
    forces: list[float] = Field(min_length=1, max_length=MAX_PUSH_POINTS, description="user force [N]")

    @model_validator(mode="after")
    def _check(self) -> "PushProfile":
        if len(self.times) != len(self.forces):
            raise InputError("push.forces", "must have as many values as push.times")
        if any(not math.isfinite(v) or abs(v) > _BIG for v in self.times + self.forces):
            raise InputError("push", "times and forces must be finite and below 1e12 in magnitude")
        if self.times[0] < 0 or any(b <= a for a, b in zip(self.times, self.times[1:])):
            raise InputError("push.times", "must be ≥ 0 and strictly increasing")
        return self


class RelaySpec(BaseModel):
    """Åström–Hägglund relay: the motor force is -h·sign(measured position)."""

    model_config = _STRICT
    amplitude: float = Field(default=1.0, gt=0, le=_BIG, description="h, relay force amplitude [N]")


class Marker(BaseModel):
    """An effect whose parameters come from the device (delay, cable, human, force sensor)."""

    model_config = _STRICT


class Quantization(BaseModel):
    """Encoder quantisation; without ``resolution`` the device's ``encoder_resolution`` is used."""

    model_config = _STRICT
    resolution: float | None = Field(default=None, gt=0, le=1.0,
                                     description="q, encoder resolution [m]; measured position = q·round(x/q); "
                                                 "absent: the device's encoder_resolution")


class CoulombFriction(BaseModel):
    """Coulomb friction on the motor-side mass; without ``force`` the device's ``coulomb_friction`` is used."""

    model_config = _STRICT
    force: float | None = Field(default=None, ge=0, le=_BIG,
                                description="c, Coulomb friction force on the motor-side mass [N]; absent: the "
                                            "device's coulomb_friction")


class Saturation(BaseModel):
    model_config = _STRICT
    max_force: float = Field(gt=0, le=_BIG, description="largest motor force magnitude [N]")


class ForceFeedforward(BaseModel):
    """Force feedforward of §5: motor force += K_f·D(z)·(sampled filtered user force)."""

    model_config = _STRICT
    gain: float = Field(ge=0, le=1e6, description="K_f, force feedforward gain [-]")
    cutoff_hz: float | None = Field(default=None, gt=0, le=1e9,
                                    description="D(z) Butterworth cutoff [Hz] (bilinear, prewarped); none = no filter")
    order: int = Field(default=2, ge=1, le=8, description="D(z) Butterworth order")


class Effects(BaseModel):
    """The effects the scene names; an absent key is not simulated."""

    model_config = _STRICT
    delay: Marker | None = Field(default=None, description="the device's loop delay t_d (exact, any real)")
    cable_mode: Marker | None = Field(default=None, description="the device's two-mass cable model (§4)")
    human: Marker | None = Field(default=None, description="the device's human grasp Z_h (eq. 30) on the body mass")
    force_sensor_filter: Marker | None = Field(default=None, description="the device's sensor filter G_f (eq. 31)")
    force_feedforward: ForceFeedforward | None = None
    quantization: Quantization | None = None
    coulomb_friction: CoulombFriction | None = None
    saturation: Saturation | None = None

    def named(self) -> tuple[str, ...]:
        return tuple(n for n in EFFECT_NAMES if getattr(self, n, None) is not None)


class Scene(BaseModel):
    """One experiment on one device."""

    model_config = _STRICT
    experiment: Literal["release", "push", "relay"] = Field(
        description="release: start in the wall; push: user force profile; relay: relay feedback (Fig. 18)")
    duration: float = Field(gt=0, le=1e6, description="simulated time [s]")
    controller: WallController | None = Field(default=None, description="the virtual wall (release, push)")
    initial: InitialState = Field(default_factory=InitialState)
    push: PushProfile | None = None
    relay: RelaySpec | None = None
    effects: Effects = Field(default_factory=Effects)
    output_points: int = Field(default=2000, ge=2, le=MAX_OUTPUT_POINTS,
                               description="points of the downsampled trajectory in the answer")

    @model_validator(mode="after")
    def _consistent(self) -> "Scene":
        if self.experiment == "relay":
            if self.controller is not None:
                raise InputError("scene.controller", "a relay experiment has no wall controller (the relay is the controller)")
            if self.push is not None:
                raise InputError("scene.push", "only a push experiment takes a force profile")
        else:
            if self.controller is None:
                raise InputError("scene.controller", f"a {self.experiment} experiment needs the wall controller")
            if self.relay is not None:
                raise InputError("scene.relay", "only a relay experiment takes relay settings")
            if self.experiment == "push" and self.push is None:
                raise InputError("scene.push", "a push experiment needs the force profile")
            if self.experiment == "release" and self.push is not None:
                raise InputError("scene.push", "a release experiment takes no force profile (use experiment 'push')")
        if self.effects.force_feedforward is not None and self.effects.force_sensor_filter is None:
            raise InputError("scene.effects.force_feedforward", "needs force_sensor_filter too (the sampled sensor "
                             "force must come through G_f, eq. 31; without it the loop is algebraic)")
        return self
