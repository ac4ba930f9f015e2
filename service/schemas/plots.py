"""Schemas of /v1/plots/boundary and /v1/plots/bode."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, Field

from optim.stability.boundary import MAX_BOUNDARY_POINTS
from optim.stability.frequency_response import MAX_RESPONSE_POINTS

from .common import STRICT, Controller, Device

__all__ = ["BoundaryPlotRequest", "BodePlotRequest"]


class BoundaryPlotRequest(BaseModel):
    model_config = STRICT
    device: Device
    damping_max: float | None = Field(default=None, gt=0, le=1e15, description="largest B [N·s/m]; default B_max")
    points: int = Field(default=50, ge=2, le=MAX_BOUNDARY_POINTS, description="values of B on the curve")
    format: Literal["png", "svg"] = Field(default="png", description="image format")


class BodePlotRequest(BaseModel):
    model_config = STRICT
    device: Device
    controller: Controller | None = Field(
        default=None, description="the wall: its B sets the crossovers marked; with B = 0 its 1/K line is drawn")
    points: int = Field(default=400, ge=10, le=MAX_RESPONSE_POINTS, description="frequencies on the diagram")
    format: Literal["png", "svg"] = Field(default="png", description="image format")
