"""POST /v1/design/hardware: the loosest hardware parameter that still renders a target wall."""

from __future__ import annotations

import dataclasses

from fastapi import APIRouter

from optim.hardware import HardwareDesign, HardwareTarget, design_hardware
from service.errors import NumericInputError
from service.executor import BoundedExecutor, Compute
from service.schemas.design_hardware import HardwareDesignRequest, HardwareDesignResponse

from .design_stiffness import _finite

router = APIRouter()


def run_hardware(request: HardwareDesignRequest, compute: BoundedExecutor) -> HardwareDesign:
    """The design in a compute worker (tens of exact designs: never inline), under the request time budget."""
    t = request.target
    try:
        return compute.run(design_hardware, request.device,
                           HardwareTarget(t.stiffness, t.min_gain_margin_db, t.max_damping),
                           request.free, points=request.points, cost_ms=None)
    except ValueError as exc:
        field, _, msg = str(exc).partition(": ")
        raise NumericInputError(field, msg) from None


@router.post("/v1/design/hardware", response_model=HardwareDesignResponse, tags=["design"])
def design_hardware_route(request: HardwareDesignRequest, compute: Compute) -> HardwareDesignResponse:
    return HardwareDesignResponse(**_finite(dataclasses.asdict(run_hardware(request, compute))))
