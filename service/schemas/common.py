"""Request pieces shared by several endpoints."""

from __future__ import annotations

from typing import Annotated

from pydantic import AfterValidator, BaseModel, ConfigDict, Field

from models.device import Device as CoreDevice
from optim.domain import check_device_domain

STRICT = ConfigDict(extra="forbid", allow_inf_nan=False)


def _in_domain(device: CoreDevice) -> CoreDevice:
    check_device_domain(device)  # ValueError("field: rule") → 422 at body.device.<field>
    return device


#: The device of every request: models.device.Device, inside the numerics' validated domain (optim.domain).
Device = Annotated[CoreDevice, AfterValidator(_in_domain)]

LHIFAM_RIGID = {"mass": 5.4, "damping": 3.5, "sample_time": 0.001}


def device_examples(**extra: object) -> dict[str, dict[str, object]]:
    """Named OpenAPI examples (Swagger UI's example menu): the presets, the rigid LHifAM, a delayed device."""
    return {
        "lhifam-rigid": {"summary": "LHifAM, rigid model (chapter Table 2/3)", "value": {"device": LHIFAM_RIGID, **extra}},
        "lhifam": {"summary": "preset lhifam: two-mass cable model (§4)", "value": {"device": {"preset": "lhifam"}, **extra}},
        "lhifam-reduced-pretension": {"summary": "preset lhifam-reduced-pretension (§4.3)",
                                      "value": {"device": {"preset": "lhifam-reduced-pretension"}, **extra}},
        "phantom-1.0": {"summary": "preset phantom-1.0 (rotary units)", "value": {"device": {"preset": "phantom-1.0"}, **extra}},
        "delayed": {"summary": "LHifAM rigid with 1.5 samples of loop delay",
                    "value": {"device": {**LHIFAM_RIGID, "delay": 0.0015}, **extra}},
    }


class Controller(BaseModel):
    """The virtual wall C(z) = K + B(1 − z⁻¹)/T."""

    model_config = STRICT
    stiffness: float = Field(gt=0, le=1e15, description="K [N/m or N·m/rad]")
    damping: float = Field(default=0.0, ge=0, le=1e15, description="B [N·s/m or N·m·s/rad]")


class CrossoverOut(BaseModel):
    frequency: float = Field(description="ω [rad/s]")
    stiffness: float = Field(description="K [N/m] that puts a closed-loop pole at e^{jωT}")


__all__ = ["Device", "Controller", "CrossoverOut", "STRICT", "LHIFAM_RIGID", "device_examples"]
