"""POST /v1/analysis/workspace: K_cr over a multi-DOF device's poses and wall normals (thin call into optim)."""

from __future__ import annotations

from dataclasses import asdict

from fastapi import APIRouter

from optim.workspace.analysis import PoseSpec, analyse_workspace

from ..executor import Compute
from ..schemas.workspace import WorkspaceRequest, WorkspaceResponse
from .analysis import field_error

router = APIRouter(prefix="/v1/analysis", tags=["analysis"])


@router.post("/workspace", response_model=WorkspaceResponse, operation_id="analyse_workspace",
             summary="K_cr of the wall at every pose and normal of a multi-DOF device (URDF)")
async def workspace(req: WorkspaceRequest, compute: Compute) -> WorkspaceResponse:
    kin = req.device.kinematics
    poses = req.poses
    spec = PoseSpec(explicit=None if poses.explicit is None else tuple(tuple(q) for q in poses.explicit),
                    grid_num=None if poses.grid is None else poses.grid.num,
                    lhs_samples=None if poses.latin_hypercube is None else poses.latin_hypercube.samples,
                    lhs_seed=0 if poses.latin_hypercube is None else poses.latin_hypercube.seed)
    try:
        result, elapsed = await compute.arun(
            analyse_workspace, kin.urdf, kin.preset, kin.end_effector, kin.armature, kin.joint_damping, spec,
            req.normals, req.device.sample_time, req.device.delay,
            req.controller.damping if req.controller else 0.0)
    except ValueError as exc:
        raise field_error(exc) from exc
    out = asdict(result)
    out["elapsed_ms"] = elapsed
    return WorkspaceResponse(**out)
