"""POST /v1/design/hardware: the loosest hardware parameter that still renders a target wall and/or
force-feedforward gain (apparent mass)."""

from __future__ import annotations

import dataclasses
import time

from fastapi import APIRouter

from optim.errors import InputError
from optim.hardware.design import HardwareDesign, HardwareTarget, design_hardware, loose_direction
from optim.verification_hardware import verify_hardware_design
from service.errors import solver_trouble
from service.executor import BoundedExecutor, Compute
from service.routes.design_quantisation import QUANTISATION_FREE, quantisation_answer
from service.schemas.design_hardware import HardwareDesignRequest, HardwareDesignResponse
from service.schemas.verification import verification_out

router = APIRouter()


def hardware_target(request: HardwareDesignRequest) -> HardwareTarget:
    """The request's target as optim's (the same field names)."""
    return request.target.core()


async def run_hardware(request: HardwareDesignRequest, compute: BoundedExecutor) -> HardwareDesign:
    """The design in a compute worker (tens of exact designs: never inline), under the request time budget."""
    # An InputError (field, rule) answers 422 by itself (service.errors).
    value_range = None if request.range is None else (request.range.min, request.range.max)
    return await compute.arun(design_hardware, request.device, hardware_target(request), request.free,
                              points=request.points, value_range=value_range, cost_ms=None)


@router.post("/v1/design/hardware", response_model=HardwareDesignResponse, tags=["design"])
async def design_hardware_route(request: HardwareDesignRequest, compute: Compute) -> HardwareDesignResponse:
    t0 = time.perf_counter()
    if request.free in QUANTISATION_FREE:
        return await quantisation_answer(request, compute)
    try:
        design = await run_hardware(request, compute)
    except InputError:
        raise                   # 422 naming the field, as on every route (service.errors)
    except (RuntimeError, ArithmeticError, ValueError) as exc:   # numerical trouble: failed, as the other designs
        return HardwareDesignResponse(status="failed", free=request.free,
                                      direction=loose_direction(request.free, hardware_target(request)),
                                      reason=solver_trouble(exc), elapsed_ms=(time.perf_counter() - t0) * 1e3)
    data = dataclasses.asdict(design)   # non-finite numbers answer null (FiniteModel)
    if request.verify and design.status == "optimal":
        v = await compute.arun(verify_hardware_design, request.device, request.free, design.value,
                               design.controller, cost_ms=None)
        data["verification"] = verification_out(v)
    return HardwareDesignResponse(**data)
