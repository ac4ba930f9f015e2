"""POST /v1/plots/simulation?format=png|svg: the scene of /v1/simulate drawn as position, force and energy."""

from __future__ import annotations

from typing import Literal

from fastapi import APIRouter, Query
from fastapi.responses import Response

from ..executor import Compute
from ..plots_simulation import MEDIA_TYPES, plot_simulation
from ..schemas.simulate import SimulateRequest
from .simulate import run_scene

router = APIRouter(tags=["plots"])


@router.post("/v1/plots/simulation", response_class=Response,
             responses={200: {"content": {"image/png": {}, "image/svg+xml": {}}}})
def simulation_plot(req: SimulateRequest, compute: Compute,
                    format: Literal["png", "svg"] = Query("png")) -> Response:  # noqa: A002
    res, _ = run_scene(req.device, req.scene, compute)
    return Response(content=plot_simulation(res, format), media_type=MEDIA_TYPES[format])
