"""POST /v1/design/stiffness: the stiffest safe wall, with its damping, limits and sensitivities."""

from __future__ import annotations

import dataclasses
import math
import time

from fastapi import APIRouter

from optim.stiffness import StiffnessRequirements, design_stiffness
from service.schemas.design_stiffness import StiffnessDesignRequest, StiffnessDesignResponse

router = APIRouter()


def _finite(value):
    """JSON has no inf/NaN: a non-finite number becomes null (its reason travels beside it)."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


@router.post("/v1/design/stiffness", response_model=StiffnessDesignResponse, tags=["design"])
def design_stiffness_route(request: StiffnessDesignRequest) -> StiffnessDesignResponse:
    # a plain def: FastAPI runs it in the threadpool, and the CasADi solver cache is per thread
    t0 = time.perf_counter()
    req = StiffnessRequirements(**request.requirements.model_dump())
    try:
        design = design_stiffness(request.device, req)
    except (RuntimeError, ArithmeticError, ValueError) as exc:   # CasADi raises RuntimeError on solver trouble
        return StiffnessDesignResponse(status="failed", reason=f"solver trouble: {exc}",
                                       elapsed_ms=(time.perf_counter() - t0) * 1e3)
    data = _finite(dataclasses.asdict(design))
    return StiffnessDesignResponse(**data)
