"""One least-squares problem: a model structure, the data, what is fixed and what is free.

The residual vector r(θ) is what scipy.optimize.least_squares minimises:
  * time series: ŷ(θ) − y, with ŷ the exact sampled model's encoder position plus a constant offset
    (the encoder's zero is arbitrary) and, with ``friction``, a Coulomb term;
  * frequency response: (Ĥ(θ) − H)/|H| (relative error), real and imaginary parts stacked.

Coulomb friction (time series only) is the force −F_c·sign(v[k]) held over each sample on the motor
mass, without the loop delay (it is physical, not commanded), where v[k] is the velocity read from the
measured position (a Savitzky–Golay derivative).  That makes F_c a linear parameter with an exact
regressor, at the price of an approximation: stick and the sign change inside a sample are not
modelled (the scene simulator's event integrator, models/simulation/friction.py, models them; the tests generate
their data with it and measure the bias this leaves).

The Jacobian is exact for the linear parameters (offset, F_c) and central differences of the exact
model for the others (relative step 6e-6: truncation and rounding both ≈ 1e-10 relative).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.signal import savgol_filter

from optim.identification.data import FrequencyResponseData, TimeSeriesData
from optim.identification.models import PARAMS, POSITIVE, ModelName, device_from, response, simulate_position

__all__ = ["Problem", "friction_regressor"]

_REL_STEP = 6e-6


def friction_regressor(position: np.ndarray, sample_time: float) -> np.ndarray:
    """−sign(v[k]) with v from a Savitzky–Golay derivative of the measured position (0 where it rests)."""
    n = len(position)
    win = min(11, n - (1 - n % 2))
    v = savgol_filter(position, window_length=max(win, 3), polyorder=2, deriv=1, delta=sample_time)
    # Below one quantisation step per window the device is taken as at rest (sign 0).
    steps = np.diff(np.unique(position))
    q = float(np.min(steps)) if steps.size else 0.0
    rest = q / (max(win, 3) * sample_time)
    return -np.where(np.abs(v) > rest, np.sign(v), 0.0)


@dataclass
class Problem:
    model: ModelName
    data: TimeSeriesData | FrequencyResponseData
    fixed: dict[str, float]
    friction: bool = False
    sign_regressor: np.ndarray | None = None
    """−sign(v[k]) of the friction term; default: read from the measured position (friction_regressor)"""
    free: tuple[str, ...] = field(init=False)
    nuisance: tuple[str, ...] = field(init=False)
    evaluations: int = field(default=0, init=False)

    def __post_init__(self) -> None:
        self.free = tuple(p for p in PARAMS[self.model] if p not in self.fixed)
        ts = isinstance(self.data, TimeSeriesData)
        self.nuisance = (("offset",) if ts else ()) + (("friction",) if self.friction else ())
        if ts:
            self._u = self.data.force
            self._y = self.data.position
            if self.friction and self.sign_regressor is None:
                self.sign_regressor = friction_regressor(self.data.position, self.data.sample_time)
        else:
            self._h = self.data.response
            self._w = 1.0 / np.abs(self.data.response)

    @property
    def sample_time(self) -> float:
        return self.data.sample_time

    @property
    def names(self) -> tuple[str, ...]:
        """Order of the least-squares vector: the free physical parameters, then offset and friction."""
        return self.free + self.nuisance

    @property
    def measured(self) -> np.ndarray:
        if isinstance(self.data, TimeSeriesData):
            return self._y
        return np.concatenate([self._h.real * self._w, self._h.imag * self._w])

    def values(self, x: np.ndarray) -> dict[str, float]:
        out = dict(self.fixed)
        out.update({n: float(v) for n, v in zip(self.names, x)})
        return out

    def device(self, x: np.ndarray):
        v = self.values(x)
        return device_from(self.model, {p: v[p] for p in PARAMS[self.model]}, self.sample_time)

    def typical(self, name: str, values: dict[str, float]) -> float:
        """A magnitude for steps and scaling where the value itself may be 0: T for the delay, for a
        damping the δ = bT/m = 1e-4 of a lightly damped device (LHifAM: 6.5e-4)."""
        if name == "delay":
            return self.sample_time
        mass = values.get("mass") or values.get("cable.motor_mass", 0.0) + values.get("cable.body_mass", 0.0)
        if name == "friction":
            return 1e-3 * float(np.max(np.abs(self.data.force))) if isinstance(self.data, TimeSeriesData) else 1.0
        if "damping" in name:
            return 1e-4 * mass / self.sample_time
        return 1e-12

    # -- the model's output --------------------------------------------------------------------------
    def _physical_output(self, values: dict[str, float]) -> np.ndarray:
        dev = device_from(self.model, {p: values[p] for p in PARAMS[self.model]}, self.sample_time)
        self.evaluations += 1
        if isinstance(self.data, TimeSeriesData):
            return simulate_position(dev, self._u)
        h = response(dev, self.data.frequency, self.data.model_kind)
        return np.concatenate([h.real * self._w, h.imag * self._w])

    def _friction_column(self, values: dict[str, float]) -> np.ndarray:
        v = {p: values[p] for p in PARAMS[self.model]}
        v["delay"] = 0.0
        return simulate_position(device_from(self.model, v, self.sample_time), self.sign_regressor)

    def output(self, x: np.ndarray) -> np.ndarray:
        v = self.values(x)
        out = self._physical_output(v)
        if "offset" in self.nuisance:
            out = out + v["offset"]
        if self.friction:
            out = out + v["friction"] * self._friction_column(v)
        return out

    def residual(self, x: np.ndarray) -> np.ndarray:
        return self.output(x) - self.measured

    def jacobian(self, x: np.ndarray, lower: np.ndarray | None = None) -> np.ndarray:
        x = np.asarray(x, float)
        v = self.values(x)
        cols = []
        fric = self._friction_column(v) if self.friction else None
        for i, name in enumerate(self.names):
            if name == "offset":
                cols.append(np.ones(len(self.measured)))
                continue
            if name == "friction":
                cols.append(fric)
                continue
            h = _REL_STEP * max(abs(x[i]), self.typical(name, v))
            lo = 0.0 if lower is None else lower[i]
            xp, xm = x.copy(), x.copy()
            xp[i] += h
            if x[i] - h >= lo and (name not in POSITIVE or x[i] - h > 0):
                xm[i] -= h
                cols.append((self.output(xp) - self.output(xm)) / (2 * h))
            else:                               # at the bound: one-sided, second order
                x2 = x.copy()
                x2[i] += 2 * h
                cols.append((-3 * self.output(x) + 4 * self.output(xp) - self.output(x2)) / (2 * h))
        return np.column_stack(cols)
