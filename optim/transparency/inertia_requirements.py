"""What an inertia (force-feedforward) design must respect (chapter §5.2).

The one definition of these rules: the HTTP request of POST /v1/design/inertia uses this model (the service's
``InertiaRequirementsIn`` only adds the robust design's ``uncertainty`` and JSON-number strictness), so a bound,
a cross-field rule and their messages live here alone.  Rules that need the device (a cutoff below Nyquist, a
grasp within the numeric domain) are optim.transparency.feedforward_loop's and optim.domain's.
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from models.device import Human
from models.filters import MAX_FILTER_ORDER
from optim.errors import InputError

__all__ = ["InertiaRequirements", "MassRange", "MAX_HUMANS"]

# Lax for internal callers (as models.device.Device); the service validates JSON numbers strictly.
_CONFIG = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)

#: Most grasps a design holds for at once (each one is an exact loop at every cutoff scanned).
MAX_HUMANS = 16


class MassRange(BaseModel):
    """A range of grasp masses m_h [kg]."""

    model_config = _CONFIG
    min: float = Field(gt=0, le=1e6, description="[kg]")
    max: float = Field(gt=0, le=1e6, description="[kg]")

    @model_validator(mode="after")
    def _ordered(self) -> "MassRange":
        if self.max < self.min:
            raise InputError("max", "must be ≥ min")
        return self


class InertiaRequirements(BaseModel):
    """The gain margin, the filter's cutoff band and order, and the grasps a force-feedforward design holds for."""

    model_config = _CONFIG

    objective: Literal["min_apparent_mass", "target_apparent_mass"] | None = Field(
        default=None, description="default: target_apparent_mass when a target is given, else min_apparent_mass")
    min_gain_margin_db: float = Field(default=6.0, ge=0, le=120,
                                      description="required gain margin 20·log10(K_f,cr/K_f) [dB]")
    cutoff_min_hz: float = Field(default=10.0, gt=0, le=1e9,
                                 description="lowest cutoff [Hz] (human force bandwidth, Lawrence et al.)")
    cutoff_max_hz: float | None = Field(default=None, gt=0, le=1e9, description="highest cutoff [Hz]; default "
                                        "first cable mode ω_n/2π (eq. 24), else 0.4 × Nyquist")
    filter_order: int = Field(default=2, ge=1, le=MAX_FILTER_ORDER,
                              description=f"Butterworth order, 1-{MAX_FILTER_ORDER} (the chapter: 2)")
    target_apparent_mass: float | None = Field(default=None, gt=0, le=1e12,
                                               description="reach this apparent mass [kg] with the highest cutoff")
    human_mass_range: MassRange | None = Field(default=None, description="grasp masses [kg] to hold for (worst "
                                               "case); damping and stiffness of the base grasp")
    humans: list[Human] | None = Field(default=None, min_length=1, max_length=MAX_HUMANS,
                                       description="explicit grasps (finger, hand, arm); worst case")
    pareto_points: int = Field(default=17, ge=2, le=201, description="cutoffs of the exact Pareto scan (geometric)")

    @model_validator(mode="after")
    def _one_human_spec(self) -> "InertiaRequirements":
        if self.humans is not None and self.human_mass_range is not None:
            raise InputError("human_mass_range", "give either humans or human_mass_range, not both")
        if self.objective == "target_apparent_mass" and self.target_apparent_mass is None:
            raise InputError("target_apparent_mass", "objective target_apparent_mass needs target_apparent_mass")
        if self.objective == "min_apparent_mass" and self.target_apparent_mass is not None:
            raise InputError("target_apparent_mass", "objective min_apparent_mass takes no target_apparent_mass")
        return self
