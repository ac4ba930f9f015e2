"""POST /v1/plots/simulation?format=png|svg: the scene of /v1/simulate drawn as position, force and energy."""

from __future__ import annotations

from fastapi import APIRouter
from fastapi.responses import Response

from ..executor import Compute
from ..jobs import simulation_plot_job
from ..plots_simulation import MEDIA_TYPES
from ..schemas.plots import FormatQuery, image_format
from ..schemas.simulate import SimulateRequest
from .simulate import run_scene

router = APIRouter(tags=["plots"])


@router.post("/v1/plots/simulation", response_class=Response,
             responses={200: {"content": {"image/png": {}, "image/svg+xml": {}}}})
async def simulation_plot(req: SimulateRequest, compute: Compute,
                    format: FormatQuery = None) -> Response:  # noqa: A002
    format = image_format(format)  # noqa: A001
    # Simulated and drawn in a compute worker, under the request time budget.
    image = await run_scene(req.device, req.scene, compute, simulation_plot_job, format)
    return Response(content=image, media_type=MEDIA_TYPES[format])
