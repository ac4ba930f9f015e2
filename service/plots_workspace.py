"""The workspace map as a figure: K_cr over a 2-D slice of joint space, with the worst normal's direction
(headless matplotlib; drawn from optim.workspace's own results, in a compute worker)."""

from __future__ import annotations

import io
import math
from typing import Literal, Sequence

import matplotlib

matplotlib.use("Agg")
matplotlib.rcParams["svg.hashsalt"] = "zwidth"

import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from models.errors import InputError  # noqa: E402
from optim.workspace.analysis import device_kinematics  # noqa: E402
from optim.workspace.workspace import workspace_map  # noqa: E402

__all__ = ["workspace_slice_job", "workspace_figure"]


def workspace_figure(xs: np.ndarray, ys: np.ndarray, kcr: np.ndarray, arrows: np.ndarray | None,
                     names: tuple[str, str], title: str) -> Figure:
    fig = Figure(figsize=(6.4, 5.0), dpi=100)
    ax = fig.add_subplot()
    mesh = ax.pcolormesh(xs, ys, kcr.T, shading="nearest", cmap="viridis", gid="kcr")
    fig.colorbar(mesh, ax=ax, label="critical stiffness $K_{cr}$ [N/m]")
    if arrows is not None:   # the worst normal's in-plane components (x, y of the base frame)
        gx, gy = np.meshgrid(xs, ys, indexing="ij")
        ax.quiver(gx, gy, arrows[..., 0], arrows[..., 1], color="w", pivot="mid", headwidth=0, headlength=0,
                  headaxislength=0, scale=25, width=0.004, gid="normals",
                  label="worst normal (base x, y components)")
        ax.legend(fontsize="small", loc="upper right")
    finite = np.where(np.isfinite(kcr), kcr, np.inf)
    i, j = np.unravel_index(int(np.argmin(finite)), finite.shape)
    if math.isfinite(float(finite[i, j])):
        ax.plot([xs[i]], [ys[j]], "o", color="C3", gid="worst",
                label=f"lowest K_cr = {finite[i, j]:.5g} N/m")
        ax.legend(fontsize="small", loc="upper right")
    ax.set_xlabel(f"joint {names[0]} [rad or m]")
    ax.set_ylabel(f"joint {names[1]} [rad or m]")
    ax.set_title(title, fontsize=9)
    fig.subplots_adjust(left=0.12, right=0.95, bottom=0.11, top=0.9)
    return fig


def workspace_slice_job(urdf: str | None, preset: str | None, end_effector: str | None,
                        armature: Sequence[float] | None, joint_damping: Sequence[float] | None,
                        joints: tuple[int, int], fixed: Sequence[float] | None, points: int,
                        normals: list[list[float]] | Literal["worst"], sample_time: float, delay: float,
                        damping: float, fmt: str) -> bytes:
    """K_cr on a points × points grid of two joints over their limits, the others at ``fixed`` (default the middle
    of their limits); singular poses are left blank."""
    model = device_kinematics(urdf, preset, end_effector, armature, joint_damping)
    jx, jy = joints
    for name, j in (("x_joint", jx), ("y_joint", jy)):
        if not 0 <= j < model.dof:
            raise InputError(name, f"a joint index 0…{model.dof - 1}")
    if jx == jy and model.dof > 1:
        raise InputError("y_joint", "must differ from x_joint")
    lo, hi = model.lower, model.upper
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        raise InputError("device.kinematics.urdf", "the slice needs finite joint limits")
    base = (lo + hi) / 2 if fixed is None else np.asarray(fixed, dtype=float)
    if base.shape != (model.dof,):
        raise InputError("fixed", f"one value per joint ({model.dof})")
    xs, ys = np.linspace(lo[jx], hi[jx], points), np.linspace(lo[jy], hi[jy], points)
    kcr = np.full((points, points), np.nan)
    arrows = np.zeros((points, points, 2)) if normals == "worst" else None
    for i, x in enumerate(xs):
        for j, y in enumerate(ys):
            q = base.copy()
            q[jx], q[jy] = x, y
            try:
                res = workspace_map(model, [q], normals, sample_time, delay, damping)
            except InputError:
                continue   # a singular pose: left blank
            kcr[i, j] = res.minimum_critical_stiffness
            if arrows is not None:
                arrows[i, j] = res.worst.normal[:2]
    kind = "each pose's worst normal" if normals == "worst" else f"{len(normals)} given normal(s)"
    title = (f"workspace K_cr: T = {sample_time * 1e3:g} ms, t_d = {delay * 1e3:g} ms, B = {damping:g} N·s/m, "
             f"{kind}")
    fig = workspace_figure(xs, ys, kcr, arrows, (model.joint_names[jx], model.joint_names[jy]), title)
    buf = io.BytesIO()
    fig.savefig(buf, format=fmt)
    return buf.getvalue()
