"""POST /v1/plots/robust and /v1/plots/hardware?format=png|svg."""

from __future__ import annotations

from fastapi import APIRouter
from fastapi.responses import Response
from pydantic import ConfigDict, Field

from optim.design_ladder import is_rendered
from optim.errors import InputError
from optim.robust.box import UncertaintyBox

from ..errors import numerics_refused
from ..executor import Compute
from ..jobs import hardware_plot_job, robust_slice_job
from ..plots_robust import MEDIA_TYPES
from ..schemas.design_hardware import HardwareDesignRequest
from ..schemas.design_stiffness import StiffnessDesignRequest
from ..schemas.plots import FormatQuery, image_format
from .design_hardware import hardware_target
from .design_stiffness import input_error

router = APIRouter(tags=["plots"])
_IMAGE = {200: {"content": {"image/png": {}, "image/svg+xml": {}}}}


class RobustPlotRequest(StiffnessDesignRequest):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    x: str | None = Field(None, description="uncertain path on the x axis (default: the first)")
    y: str | None = Field(None, description="uncertain path on the y axis (default: the second)")
    points: int = Field(41, ge=5, le=121, description="grid points per axis")


@router.post("/v1/plots/robust", response_class=Response, responses=_IMAGE)
async def robust_plot(req: RobustPlotRequest, compute: Compute,
                format: FormatQuery = None) -> Response:  # noqa: A002
    format = image_format(format)  # noqa: A001
    unc = req.requirements.uncertainty
    if not unc:
        raise InputError("requirements.uncertainty", "the robust plot needs at least one uncertain path")
    ranges = {k: (v.min, v.max) for k, v in unc.items()}
    try:
        box = UncertaintyBox.from_ranges(req.device, ranges)
    except ValueError as exc:
        raise input_error(exc) from None
    paths = list(box.paths)
    x = req.x or paths[0]
    y = req.y or (paths[1] if len(paths) > 1 else paths[0])
    for name, p in (("x", x), ("y", y)):
        if p not in paths:
            raise InputError(name, f"{p!r} is not one of the uncertain paths {paths}")
    requirements = req.requirements.core()
    c = req.controller
    mass = c.mass if c is not None else 0.0
    vfilter = c.velocity_filter if c is not None else None
    render = None
    if is_rendered(requirements, mass, vfilter):     # the rendered box (optim.robust.rendered_stiffness)
        if req.method != "exact":
            raise InputError("method", "designs of a rendered wall are computed on the exact rung only")
        render = (vfilter if vfilter is not None else requirements.velocity_filter, mass)
    try:  # the robust design and the points² exact analyses of the slice: always a worker
        image = await compute.arun(robust_slice_job, req.device, requirements, box, x, y, req.points,
                                   req.requirements.min_gain_margin_db, format, render, cost_ms=None)
    except InputError:
        raise
    except ValueError as exc:
        raise input_error(exc) from None
    return Response(content=image, media_type=MEDIA_TYPES[format])


@router.post("/v1/plots/hardware", response_class=Response, responses=_IMAGE)
async def hardware_plot(req: HardwareDesignRequest, compute: Compute,
                        format: FormatQuery = None) -> Response:  # noqa: A002
    format = image_format(format)  # noqa: A001
    if req.verify:
        raise InputError("verify", "a plot carries no verification: use POST /v1/design/hardware")
    value_range = None if req.range is None else (req.range.min, req.range.max)
    # tens of exact designs, then the drawing: always a worker, under the budget; an InputError answers 422
    try:
        image = await compute.arun(hardware_plot_job, req.device, hardware_target(req), req.free, req.points, format,
                                   value_range, cost_ms=None)
    except InputError:
        raise
    except ValueError as exc:   # e.g. matplotlib refusing a log axis when every value is ≤ 0: a 422, never a 500
        raise numerics_refused(exc, "device") from None
    return Response(content=image, media_type=MEDIA_TYPES[format])
