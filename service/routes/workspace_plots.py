"""POST /v1/plots/workspace?format=png|svg: K_cr over a 2-D slice of a multi-DOF device's joint space."""

from __future__ import annotations

from fastapi import APIRouter
from fastapi.responses import Response
from pydantic import BaseModel, Field

from optim.errors import InputError

from ..executor import Compute
from ..plots_robust import MEDIA_TYPES
from ..plots_workspace import workspace_slice_job
from ..schemas.common import STRICT, Controller
from ..schemas.plots import FormatQuery, image_format
from ..schemas.workspace import WorkspaceDevice
from .analysis import field_error

router = APIRouter(tags=["plots"])
_IMAGE = {200: {"content": {"image/png": {}, "image/svg+xml": {}}}}


class WorkspacePlotRequest(BaseModel):
    model_config = {**STRICT, "json_schema_extra": {"examples": [
        {"device": {"sample_time": 0.001, "delay": 0.001, "kinematics": {"preset": "planar-2link"}}, "points": 11},
        {"device": {"sample_time": 0.001, "kinematics": {"preset": "planar-2link"}}, "controller":
         {"stiffness": 100.0, "damping": 0.2}, "normals": [[0.0, 1.0, 0.0]], "points": 9}]}}
    device: WorkspaceDevice
    controller: Controller | None = Field(default=None, description="B [N·s/m] of the wall")
    x_joint: int = Field(default=0, ge=0, le=63, description="joint index on the x axis")
    y_joint: int = Field(default=1, ge=0, le=63, description="joint index on the y axis")
    fixed: list[float] | None = Field(default=None, max_length=64,
                                      description="the other joints' values (default: their limits' middles)")
    points: int = Field(default=21, ge=3, le=41, description="grid points per axis")
    normals: list[list[float]] | str = Field(default="worst", description="unit normals, or \"worst\"")


@router.post("/v1/plots/workspace", response_class=Response, responses=_IMAGE, operation_id="plot_workspace",
             summary="Workspace map: K_cr over two joints, with the worst normal's direction")
async def workspace_plot(req: WorkspacePlotRequest, compute: Compute,
                         format: FormatQuery = None) -> Response:  # noqa: A002
    format = image_format(format)  # noqa: A001
    if isinstance(req.normals, str) and req.normals != "worst":
        raise InputError("normals", "a list of unit normals, or \"worst\"")
    kin = req.device.kinematics
    try:
        image = await compute.arun(workspace_slice_job, kin.urdf, kin.preset, kin.end_effector, kin.armature,
                                   kin.joint_damping, (req.x_joint, req.y_joint), req.fixed, req.points, req.normals,
                                   req.device.sample_time, req.device.delay,
                                   req.controller.damping if req.controller else 0.0, format, cost_ms=None)
    except ValueError as exc:
        raise field_error(exc) from exc
    return Response(content=image, media_type=MEDIA_TYPES[format])
