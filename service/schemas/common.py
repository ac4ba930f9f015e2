"""Request pieces shared by several endpoints."""

from __future__ import annotations

from typing import Annotated, Any, Callable, TypeVar

from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Field,
    ValidatorFunctionWrapHandler,
    WrapValidator,
    model_validator,
)

from models.device import Device as CoreDevice
from models.errors import InputError
from models.simulation.scene import Scene as CoreScene
from models.velocity_filter import MAX_VIRTUAL_MASS, VelocityFilter
from optim.domain import check_device_domain

#: Every request model: unknown fields refused, finite numbers only, and a number must be a JSON number
#: (strict: ``true`` and ``"5.4"`` are refused instead of read as 1 and 5.4; an integer is a valid float,
#: a float with a fraction is not a valid integer).
STRICT = ConfigDict(extra="forbid", allow_inf_nan=False, strict=True)

M = TypeVar("M", bound=BaseModel)


def json_numbers(model: type[M]) -> Callable[[Any, ValidatorFunctionWrapHandler], M]:
    """Validate a core model (models/: lax by default, for internal callers) strictly, as STRICT does for
    the service's own models; its nested models follow (pydantic's runtime strict flag reaches them)."""

    def validate(value: Any, handler: ValidatorFunctionWrapHandler) -> M:
        return model.model_validate(value, strict=True) if isinstance(value, dict) else handler(value)

    return validate


def _in_domain(device: CoreDevice) -> CoreDevice:
    check_device_domain(device)  # ValueError("field: rule") → 422 at body.device.<field>
    return device


#: The device of every request: models.device.Device, inside the numerics' validated domain (optim.domain).
Device = Annotated[CoreDevice, WrapValidator(json_numbers(CoreDevice)), AfterValidator(_in_domain)]
#: The scene of a simulation: models.simulation.scene.Scene with JSON numbers only.
Scene = Annotated[CoreScene, WrapValidator(json_numbers(CoreScene))]

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


_MASS = Field(default=0.0, ge=-MAX_VIRTUAL_MASS, le=MAX_VIRTUAL_MASS,
              description="M, virtual mass [kg or kg·m²] rendered as M·A(z), A = V·(1 − z⁻¹)/T; negative "
                          "compensates the device's inertia")
_FILTER = Field(default=None, description="the velocity the damper sees, V(z); null: the backward difference "
                                          "(1 − z⁻¹)/T (ARCHITECTURE.md, \"The rendered virtual environment\")")


class RenderedEnvironment(BaseModel):
    """What a wall renders besides K and B: C(z) = K + B·V(z) + M·A(z)."""

    model_config = STRICT
    mass: float = _MASS
    velocity_filter: VelocityFilter | None = _FILTER

    @property
    def rendered(self) -> bool:
        """Whether the request named a virtual mass or a velocity filter (even the default ones)."""
        return bool({"mass", "velocity_filter"} & self.model_fields_set)


class RenderedController(RenderedEnvironment):
    """The rendered wall C(z) = K + B·V(z) + M·A(z): today's C(z) = K + B(1 − z⁻¹)/T when mass and
    velocity_filter are absent."""

    stiffness: float | None = Field(default=None, gt=0, le=1e15, description="K [N/m or N·m/rad]; optional when "
                                                                               "mass or velocity_filter is given")
    damping: float = Field(default=0.0, ge=0, le=1e15, description="B [N·s/m or N·m·s/rad]")

    @model_validator(mode="after")
    def _stiffness_or_rendering(self) -> "RenderedController":
        if self.stiffness is None and not self.rendered:
            raise InputError("stiffness", "required unless mass or velocity_filter is given")
        return self


class CrossoverOut(BaseModel):
    frequency: float = Field(description="ω [rad/s]")
    stiffness: float = Field(description="K [N/m] that puts a closed-loop pole at e^{jωT}")


__all__ = ["Device", "Scene", "Controller", "RenderedController", "RenderedEnvironment", "CrossoverOut", "STRICT", "LHIFAM_RIGID", "device_examples",
           "json_numbers"]
