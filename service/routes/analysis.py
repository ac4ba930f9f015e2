"""POST /v1/analysis/stability and /v1/analysis/boundary: thin calls into optim."""

from __future__ import annotations

import math
from dataclasses import asdict

from fastapi import APIRouter

from optim.analysis import analyse_stability
from optim.boundary import stability_boundary

from ..errors import NumericInputError
from ..schemas.analysis import BoundaryRequest, BoundaryResponse, StabilityRequest, StabilityResponse

router = APIRouter(prefix="/v1/analysis", tags=["analysis"])


def _field_error(exc: ValueError) -> NumericInputError:
    text = str(exc)
    field, _, msg = text.partition(": ")
    return NumericInputError(field if msg else "device", msg or text)


@router.post("/stability", response_model=StabilityResponse)
def stability(req: StabilityRequest) -> StabilityResponse:
    k = req.controller.stiffness if req.controller else None
    b = req.controller.damping if req.controller else 0.0
    try:
        res = analyse_stability(req.device, k, b, req.method, req.grid_points)
    except ValueError as exc:
        raise _field_error(exc) from exc
    return StabilityResponse(**asdict(res))


@router.post("/boundary", response_model=BoundaryResponse)
def boundary(req: BoundaryRequest) -> BoundaryResponse:
    try:
        res = stability_boundary(req.device, req.damping_max, req.points)
    except ValueError as exc:
        raise _field_error(exc) from exc

    def clean(p):
        d = asdict(p)
        if d["critical_stiffness"] is not None and not math.isfinite(d["critical_stiffness"]):
            d["critical_stiffness"] = None
        return d
    return BoundaryResponse(points=[clean(p) for p in res.points], optimum=clean(res.optimum),
                            max_stable_damping=res.max_stable_damping, method="exact", elapsed_ms=res.elapsed_ms)
