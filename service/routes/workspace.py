"""POST /v1/analysis/workspace: K_cr over a multi-DOF device's poses and wall normals (thin call into optim).

A request of many poses is split into consecutive slices, one per compute worker, computed at once and joined in
order (optim.workspace.workspace.merge_points): the same points and worst as one worker's, in about 1/workers of
the time.  Each slice is a call under the request's time budget (503 past it, or when the queue is full, as for
any call); a validation error is the first slice's that raised one, in pose order.
"""

from __future__ import annotations

import asyncio
import time
from dataclasses import asdict

from fastapi import APIRouter

from optim.workspace.analysis import PoseSpec, analyse_workspace, analyse_workspace_part, pose_count
from optim.workspace.workspace import merge_points

from ..executor import Compute
from ..schemas.workspace import WorkspaceRequest, WorkspaceResponse
from .analysis import field_error

router = APIRouter(prefix="/v1/analysis", tags=["analysis"])

#: Poses × normals from which a request is split over the compute workers (below, one worker's round trip and
#: the model's parsing per slice cost more than the slice saves).
SPLIT_FROM = 64


@router.post("/workspace", response_model=WorkspaceResponse, operation_id="analyse_workspace",
             summary="K_cr of the wall at every pose and normal of a multi-DOF device (URDF)")
async def workspace(req: WorkspaceRequest, compute: Compute) -> WorkspaceResponse:
    kin = req.device.kinematics
    poses = req.poses
    spec = PoseSpec(explicit=None if poses.explicit is None else tuple(tuple(q) for q in poses.explicit),
                    grid_num=None if poses.grid is None else poses.grid.num,
                    lhs_samples=None if poses.latin_hypercube is None else poses.latin_hypercube.samples,
                    lhs_seed=0 if poses.latin_hypercube is None else poses.latin_hypercube.seed)
    args = (kin.urdf, kin.preset, kin.end_effector, kin.armature, kin.joint_damping, spec, req.normals,
            req.device.sample_time, req.device.delay, req.controller.damping if req.controller else 0.0,
            req.controller.velocity_filter if req.controller else None, req.controller.mass if req.controller else 0.0)
    count = pose_count(spec) * (1 if req.normals == "worst" else len(req.normals))
    parts = min(compute.workers, count // (SPLIT_FROM // 2)) if count >= SPLIT_FROM else 1
    try:
        if parts <= 1:
            result, elapsed = await compute.arun(analyse_workspace, *args)
        else:
            start = time.perf_counter()
            shares = await asyncio.gather(*(compute.arun(analyse_workspace_part, *args, i, parts)
                                            for i in range(parts)), return_exceptions=True)
            for share in shares:      # the first slice's error, in pose order (a timeout: every slice's budget)
                if isinstance(share, BaseException):
                    raise share
            result = merge_points(shares, req.normals)   # type: ignore[arg-type]
            elapsed = (time.perf_counter() - start) * 1e3
    except ValueError as exc:
        raise field_error(exc) from exc
    out = asdict(result)
    out["elapsed_ms"] = elapsed
    return WorkspaceResponse(**out)
