"""The uncertainty box of a robust design: dotted device paths mapped to ranges {min, max}.

A point of the box is a vector of values in the order of ``paths``; ``device_at``
builds the validated Device there (the device's own rules apply, e.g. mass > 0,
delay ≤ MAX_DELAY_SAMPLES·T).  With a cable block, ``device.mass`` and
``device.damping`` are the sums m_r + m_d and b_r + b_d (ARCHITECTURE.md) and are
not free parameters: the masses and dampings of the cable block are.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from pydantic import ValidationError

from models.device import Device
from optim.domain import check_device_domain
from optim.errors import InputError

__all__ = ["PATHS", "STIFFNESS_PATHS", "UncertaintyBox", "MAX_UNCERTAIN"]

#: every path a robust design accepts, with the unit of its range
PATHS: dict[str, str] = {
    "device.mass": "kg", "device.damping": "N·s/m", "device.sample_time": "s", "device.delay": "s",
    "device.cable.motor_mass": "kg", "device.cable.motor_damping": "N·s/m", "device.cable.body_mass": "kg",
    "device.cable.body_damping": "N·s/m", "device.cable.stiffness": "N/m", "device.cable.damping": "N·s/m",
    "device.human.mass": "kg", "device.human.damping": "N·s/m", "device.human.stiffness": "N/m",
    "device.force_sensor.time_constant": "s",
}
#: the paths that enter the stiffness loop Z[H·G_r·e^{−t_d s}] (eq. 20-21); the user's grasp and the force
#: sensor do not (they enter the force-feedforward loop of §5 only)
STIFFNESS_PATHS = frozenset(p for p in PATHS if not p.startswith(("device.human.", "device.force_sensor.")))
#: at most this many uncertain parameters: the corners (2^n) seed the scenarios
MAX_UNCERTAIN = 8


def _base_data(nominal: Device) -> dict:
    data = nominal.model_dump()
    data["preset"] = None               # every field is explicit now; a preset would be merged in again
    if data.get("cable") is not None:
        data.pop("mass")                # recomputed from the cable block (sums)
        data.pop("damping")
    return data


@dataclass(frozen=True)
class UncertaintyBox:
    """Ranges of uncertain device parameters (SI units)."""

    paths: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    nominal: Device

    @classmethod
    def from_ranges(cls, nominal: Device, ranges: Mapping[str, tuple[float, float]],
                    field: str = "requirements.uncertainty") -> "UncertaintyBox":
        """Validate the ranges against the device; errors start with the offending field (for a 422)."""
        if len(ranges) > MAX_UNCERTAIN:
            raise InputError(field, f"at most {MAX_UNCERTAIN} uncertain parameters, got {len(ranges)}")
        for path, (lo, hi) in ranges.items():
            where = f"{field}.{path}"
            if path not in PATHS:
                raise InputError(where, f"unknown path; known paths: {', '.join(PATHS)}")
            if not (math.isfinite(lo) and math.isfinite(hi)):
                raise InputError(where, "min and max must be finite")
            if lo > hi:
                raise InputError(where, f"min ({lo:g}) must be ≤ max ({hi:g})")
            parts = path.split(".")
            if len(parts) == 3 and getattr(nominal, parts[1]) is None:
                raise InputError(where, f"the device has no {parts[1]} block")
            if nominal.cable is not None and path in ("device.mass", "device.damping"):
                raise InputError(where, f"with a cable block the total {parts[1]} is the sum of the cable block's "
                                 f"two; give ranges for device.cable.motor_{parts[1]} and device.cable.body_{parts[1]}")
        paths = tuple(ranges)
        box = cls(paths, np.array([float(ranges[p][0]) for p in paths]),
                  np.array([float(ranges[p][1]) for p in paths]), nominal)
        box._check_devices(field)
        return box

    def _check_devices(self, field: str) -> None:
        """Each range end must give a valid device (alone, and all corners together)."""
        for k, path in enumerate(self.paths):
            for value in (self.lower[k], self.upper[k]):
                try:
                    check_device_domain(self._device({path: value}))
                except ValidationError as exc:
                    msg = exc.errors()[0]["msg"]
                    raise InputError(f"{field}.{path}", f"{value:g} gives an invalid device ({msg})") from None
                except ValueError as exc:  # optim.domain's dimensionless ranges ("field: rule")
                    raise InputError(f"{field}.{path}", f"{value:g} leaves the validated numeric domain ({exc})") from None
        try:
            for x in self.corners():
                check_device_domain(self.device_at(x))
        except ValidationError as exc:
            msg = exc.errors()[0]["msg"]
            raise InputError(field, f"a corner of the box gives an invalid device ({msg})") from None
        except ValueError as exc:
            raise InputError(field, f"a corner of the box leaves the validated numeric domain ({exc})") from None

    def _device(self, values: Mapping[str, float]) -> Device:
        data = _base_data(self.nominal)
        for path, value in values.items():
            parts = path.split(".")[1:]
            target = data
            for key in parts[:-1]:
                target = target[key]
            target[parts[-1]] = float(value)
        return Device.model_validate(data)

    @property
    def dim(self) -> int:
        return len(self.paths)

    def device_at(self, x: np.ndarray) -> Device:
        """The device at the box point x (values in the order of ``paths``)."""
        return self._device(dict(zip(self.paths, np.asarray(x, float))))

    def devices(self, points: np.ndarray) -> list[Device]:
        return [self.device_at(x) for x in np.atleast_2d(points)]

    def to_box(self, unit: np.ndarray) -> np.ndarray:
        """Unit-cube coordinates → box values (the ends exactly)."""
        u = np.asarray(unit, float)
        return np.where(u >= 1.0, self.upper, self.lower + u * (self.upper - self.lower))

    def to_unit(self, x: np.ndarray) -> np.ndarray:
        width = self.upper - self.lower
        return np.where(width > 0, (np.asarray(x, float) - self.lower) / np.where(width > 0, width, 1.0), 0.0)

    def nominal_point(self) -> np.ndarray:
        """The nominal device's values, clipped into the box."""
        values = []
        for path in self.paths:
            obj = self.nominal
            for key in path.split(".")[1:]:
                obj = getattr(obj, key)
            values.append(float(obj))
        return np.clip(np.array(values), self.lower, self.upper)

    def corners(self) -> np.ndarray:
        """Every corner (ranges with min = max counted once)."""
        axes = [(lo,) if lo == hi else (lo, hi) for lo, hi in zip(self.lower, self.upper)]
        return np.array(list(itertools.product(*axes)), float).reshape(-1, self.dim)

    def relevant(self, paths: frozenset[str]) -> np.ndarray:
        """Mask of the uncertain parameters (min < max) among ``paths``."""
        return np.array([p in paths and hi > lo for p, lo, hi in zip(self.paths, self.lower, self.upper)], bool)

    def describe(self, x: np.ndarray) -> dict[str, float]:
        return {p: float(v) for p, v in zip(self.paths, x)}
