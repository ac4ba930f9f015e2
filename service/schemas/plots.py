"""Schemas of /v1/plots/boundary and /v1/plots/bode."""

from __future__ import annotations

from typing import Annotated, Literal

from fastapi import Query
from pydantic import BaseModel, Field

from optim.stability.boundary import MAX_BOUNDARY_POINTS
from optim.stability.frequency_response import MAX_RESPONSE_POINTS

from .common import STRICT, Controller, Device, RenderedEnvironment

__all__ = ["BoundaryPlotRequest", "BodePlotRequest", "ImageFormat", "FormatQuery", "image_format", "BODY_FORMAT"]

ImageFormat = Literal["png", "svg"]
#: The one place of a plot's format on every plot route: the query, ``?format=png|svg`` (docs/clients.md "Plots").
FormatQuery = Annotated[ImageFormat | None, Query(description="image format: png (default) or svg")]
#: The body's ``format`` of /v1/plots/boundary, bode and identify, accepted for one more release.
BODY_FORMAT = Field(default=None, json_schema_extra={"deprecated": True},
                    description="deprecated: give ?format=png|svg in the query (the query wins when both are given)")


def image_format(query: ImageFormat | None, body: ImageFormat | None = None) -> ImageFormat:
    """The query's format, else the deprecated body field's, else png."""
    return query or body or "png"


class BoundaryPlotRequest(BaseModel):
    model_config = STRICT
    device: Device
    damping_max: float | None = Field(default=None, gt=0, le=1e15, description="largest B [N·s/m]; default B_max")
    points: int = Field(default=50, ge=2, le=MAX_BOUNDARY_POINTS, description="values of B on the curve")
    controller: RenderedEnvironment | None = Field(
        default=None, description="virtual mass and velocity filter of the walls on the boundary (default: today's "
                                  "wall); the curve is then the rendered K_cr(B), as POST /v1/analysis/boundary's")
    format: ImageFormat | None = BODY_FORMAT


class BodePlotRequest(BaseModel):
    model_config = STRICT
    device: Device
    controller: Controller | None = Field(
        default=None, description="the wall: its B sets the crossovers marked; with B = 0 its 1/K line is drawn")
    points: int = Field(default=400, ge=10, le=MAX_RESPONSE_POINTS, description="frequencies on the diagram")
    format: ImageFormat | None = BODY_FORMAT
