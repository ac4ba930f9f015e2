"""POST /v1/design/hardware: the loosest hardware parameter that still renders a target wall and/or
force-feedforward gain (apparent mass)."""

from __future__ import annotations

import dataclasses

from fastapi import APIRouter

from optim.hardware import HardwareDesign, HardwareTarget, design_hardware
from service.errors import NumericInputError
from service.executor import BoundedExecutor, Compute
from service.schemas.design_hardware import HardwareDesignRequest, HardwareDesignResponse

from .design_stiffness import _finite

router = APIRouter()


def hardware_target(request: HardwareDesignRequest) -> HardwareTarget:
    """The request's target as optim's (the same field names)."""
    return HardwareTarget(**request.target.model_dump())


async def run_hardware(request: HardwareDesignRequest, compute: BoundedExecutor) -> HardwareDesign:
    """The design in a compute worker (tens of exact designs: never inline), under the request time budget."""
    try:
        return await compute.arun(design_hardware, request.device, hardware_target(request), request.free,
                                  points=request.points, cost_ms=None)
    except ValueError as exc:
        field, _, msg = str(exc).partition(": ")
        raise NumericInputError(field, msg) from None


@router.post("/v1/design/hardware", response_model=HardwareDesignResponse, tags=["design"])
async def design_hardware_route(request: HardwareDesignRequest, compute: Compute) -> HardwareDesignResponse:
    return HardwareDesignResponse(**_finite(dataclasses.asdict(await run_hardware(request, compute))))
