"""POST /v1/identify and POST /v1/plots/identify: thin calls into optim.identification."""

from __future__ import annotations

import dataclasses
import time

import numpy as np
from fastapi import APIRouter
from fastapi.responses import Response

from optim.errors import InputError
from optim.identification import FrequencyResponseData, IdentificationResult, TimeSeriesData, identify

from ..executor import Compute
from ..jobs import identify_plot_job
from ..plots_identification import MEDIA_TYPES
from ..schemas.identify import IdentifyRequest, IdentifyResponse
from ..schemas.plots import FormatQuery, image_format

router = APIRouter(tags=["identification"])


def _data(req: IdentifyRequest) -> TimeSeriesData | FrequencyResponseData:
    d = req.data
    if d.kind == "time_series":
        if req.sample_time is not None and req.sample_time != d.sample_time:
            raise InputError("sample_time", "for a time series give the sample time in data.sample_time")
        return TimeSeriesData(sample_time=d.sample_time, force=np.asarray(d.force, float),
                              position=np.asarray(d.position, float))
    if not len(d.frequency) == len(d.real) == len(d.imag):
        raise InputError("data.real", f"frequency, real and imag must have the same length "
                                             f"({len(d.frequency)}, {len(d.real)}, {len(d.imag)})")
    return FrequencyResponseData(frequency=np.asarray(d.frequency, float),
                                 response=np.asarray(d.real, float) + 1j * np.asarray(d.imag, float),
                                 sample_time=req.sample_time or 0.001, model_kind=d.response)


async def run_identification(req: IdentifyRequest, compute: Compute) -> IdentificationResult:
    """Fit in a compute worker under the request time budget; an InputError (field, rule) answers 422."""
    return await compute.arun(identify, _data(req), req.model, req.known, req.friction, req.confidence,
                              req.max_delay, cost_ms=None)


def response_of(res: IdentificationResult) -> IdentifyResponse:
    out = dataclasses.asdict(res)
    out.pop("fitted", None)
    out["comparison"] = list(out["comparison"])
    out["warnings"] = list(out["warnings"])
    out["parameters"] = {k: {"value": p["value"], "std_error": p["std_error"], "interval": list(p["interval"])}
                         for k, p in out["parameters"].items()}
    return IdentifyResponse(**out)   # non-finite numbers answer null (FiniteModel)


@router.post("/v1/identify", response_model=IdentifyResponse)
async def identify_route(req: IdentifyRequest, compute: Compute) -> IdentifyResponse:
    t0 = time.perf_counter()
    res = await run_identification(req, compute)
    res = dataclasses.replace(res, elapsed_ms=1e3 * (time.perf_counter() - t0))
    return response_of(res)


@router.post("/v1/plots/identify", response_class=Response, tags=["plots"],
             responses={200: {"content": {"image/png": {}, "image/svg+xml": {}}}})
async def identify_plot(req: IdentifyRequest, compute: Compute,
                        format: FormatQuery = None) -> Response:  # noqa: A002
    fmt = image_format(format, req.format)
    # fitted and drawn in the worker, under the request time budget (the drawing is part of the cost)
    image = await compute.arun(identify_plot_job, _data(req), req.model, req.known, req.friction, req.confidence,
                               req.max_delay, fmt, cost_ms=None)
    return Response(content=image, media_type=MEDIA_TYPES[fmt])
