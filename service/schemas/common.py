"""Request pieces shared by several endpoints."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

from models.device import Device

STRICT = ConfigDict(extra="forbid", allow_inf_nan=False)

LHIFAM_RIGID = {"mass": 5.4, "damping": 3.5, "sample_time": 0.001}


class Controller(BaseModel):
    """The virtual wall C(z) = K + B(1 − z⁻¹)/T."""

    model_config = STRICT
    stiffness: float = Field(gt=0, le=1e15, description="K [N/m or N·m/rad]")
    damping: float = Field(default=0.0, ge=0, le=1e15, description="B [N·s/m or N·m·s/rad]")


class CrossoverOut(BaseModel):
    frequency: float = Field(description="ω [rad/s]")
    stiffness: float = Field(description="K [N/m] that puts a closed-loop pole at e^{jωT}")


__all__ = ["Device", "Controller", "CrossoverOut", "STRICT", "LHIFAM_RIGID"]
