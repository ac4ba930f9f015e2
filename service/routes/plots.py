"""POST /v1/plots/boundary and /v1/plots/bode?format=png|svg: PNG or SVG figures of the numerics' results."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Body
from fastapi.responses import Response

from models.velocity_filter import Rendering, rendering
from optim.errors import InputError

from ..executor import Compute
from ..plots import MEDIA_TYPES, bode_plot, boundary_plot
from ..schemas.common import device_examples
from ..schemas.plots import BodePlotRequest, BoundaryPlotRequest, FormatQuery, image_format
from .analysis import field_error

router = APIRouter(prefix="/v1/plots", tags=["plots"])


def _walls(controller, device) -> Rendering | None:
    """The boundary's velocity filter and virtual mass at the device's T (None: today's wall, as
    POST /v1/analysis/boundary); the filter's rules that need T as 422s under ``controller.``."""
    if controller is None or not controller.rendered:
        return None
    try:
        return rendering(controller.velocity_filter, controller.mass, device.sample_time)
    except InputError as exc:
        raise exc.under("controller.") from None

_IMAGE = {200: {"description": "the figure", "content": {
    "image/png": {"schema": {"type": "string", "format": "binary"}},
    "image/svg+xml": {"schema": {"type": "string", "format": "binary"}}}}}


@router.post("/boundary", response_class=Response, responses=_IMAGE, operation_id="plot_boundary",
             summary="Figure of the stability boundary K_cr(B) with its optimum (PNG or SVG)")
async def plot_boundary(req: Annotated[BoundaryPlotRequest, Body(openapi_examples=device_examples(points=20))],
                        compute: Compute, format: FormatQuery = None) -> Response:  # noqa: A002
    fmt = image_format(format, req.format)
    rendered = _walls(req.controller, req.device)
    try:
        # Computed and drawn in a compute worker under the budget: the drawing costs more than the numerics.
        image = await compute.arun(boundary_plot, req.device, req.damping_max, req.points, fmt, rendered,
                                   cost_ms=None)
    except ValueError as exc:
        raise field_error(exc) from exc
    return Response(image, media_type=MEDIA_TYPES[fmt])


@router.post("/bode", response_class=Response, responses=_IMAGE, operation_id="plot_bode",
             summary="Bode diagram of the sampled loop with the crossovers of K_cr(B) marked (PNG or SVG)")
async def plot_bode(req: Annotated[BodePlotRequest, Body(openapi_examples=device_examples())],
                    compute: Compute, format: FormatQuery = None) -> Response:  # noqa: A002
    fmt = image_format(format, req.format)
    b = req.controller.damping if req.controller else 0.0
    k = req.controller.stiffness if req.controller else None
    try:
        image = await compute.arun(bode_plot, req.device, b, req.points, k, fmt, cost_ms=None)
    except ValueError as exc:
        raise field_error(exc) from exc
    return Response(image, media_type=MEDIA_TYPES[fmt])
