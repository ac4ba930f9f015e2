"""Plots of robust and inverse designs (matplotlib Agg, a Figure per call: no shared pyplot state).

* robust: the margin 20·log10(K_cr(B; p)/K) over a two-parameter slice of the box (the other uncertain
  parameters at the worst device's values), worst device marked;
* hardware: the trade-off curve K*(q) with the target and the loosest value marked.
"""

from __future__ import annotations

import io
import math

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from optim.hardware import HardwareDesign
from optim.robust.box import UncertaintyBox
from optim.robust.worst_case import box_critical_stiffness

from .plots_simulation import MEDIA_TYPES

__all__ = ["plot_robust_slice", "plot_hardware", "MEDIA_TYPES", "margin_slice"]


def margin_slice(box: UncertaintyBox, stiffness: float, damping: float, worst: np.ndarray, x: str, y: str,
                 points: int = 41) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(xs, ys, margin[dB] of shape (len(ys), len(xs))) over the slice; −inf dB where K_cr = 0."""
    i, j = box.paths.index(x), box.paths.index(y)
    u = np.linspace(0.0, 1.0, points)
    base = box.to_unit(worst)
    grid = np.repeat(base[None, :], points * points, axis=0)
    uu, vv = np.meshgrid(u, u)
    grid[:, i], grid[:, j] = uu.ravel(), vv.ravel()
    kcr, _ = box_critical_stiffness(box, grid, damping)
    with np.errstate(divide="ignore"):
        margin = 20 * np.log10(kcr / stiffness)
    pts = box.to_box(grid)
    return pts[:points, i], pts[::points, j], margin.reshape(points, points)


def _save(fig: Figure, fmt: str) -> bytes:
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format=fmt)
    return buf.getvalue()


def plot_robust_slice(xs, ys, margin, worst_xy, required_db: float, labels: tuple[str, str], fmt: str = "png",
                      title: str | None = None) -> bytes:
    fig = Figure(figsize=(7, 5.5), dpi=100)
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    finite = np.where(np.isfinite(margin), margin, np.nan)
    mesh = ax.pcolormesh(xs, ys, finite, shading="auto", cmap="viridis")
    fig.colorbar(mesh, ax=ax, label="gain margin [dB]")
    if np.nanmin(finite) < required_db + 3 and np.nanmax(finite) > required_db:
        ax.contour(xs, ys, finite, levels=[required_db], colors="w", linewidths=1.0)
    ax.plot([worst_xy[0]], [worst_xy[1]], marker="x", color="r", ms=12, mew=2.5, label="worst case")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_xlabel(labels[0])
    ax.set_ylabel(labels[1])
    ax.set_title(title or "robust design: margin over the box", fontsize=10)
    return _save(fig, fmt)


def plot_hardware(design: HardwareDesign, target_stiffness: float, fmt: str = "png") -> bytes:
    fig = Figure(figsize=(7, 4.5), dpi=100)
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    q = np.array([p["value"] for p in design.curve])
    k = np.array([p["achievable_stiffness"] for p in design.curve])
    ax.plot(q, np.where(k > 0, k, np.nan), "-o", ms=3, lw=1.2, label="achievable stiffness K*")
    ax.axhline(target_stiffness, color="tab:red", lw=1, ls="--", label="target")
    for lo, hi in design.intervals:
        ax.axvspan(lo, hi, color="tab:green", alpha=0.12)
    if design.value is not None:
        ax.axvline(design.value, color="k", lw=1, label=f"loosest {design.free} = {design.value:.4g}")
    if q.size and q.min() > 0 and q.max() / q.min() > 20:
        ax.set_xscale("log")
    positive = k[k > 0]  # empty when no design was scanned (an infeasible answer has no curve) or none is stable
    if positive.size and positive.max() / positive.min() > 20:
        ax.set_yscale("log")
    if not design.curve and design.reason:
        ax.text(0.5, 0.5, design.reason, transform=ax.transAxes, ha="center", va="center", wrap=True, fontsize=8)
    ax.set_xlabel(design.free)
    ax.set_ylabel("K* [N/m]")
    ax.legend(fontsize=8)
    ax.set_title(f"hardware trade-off: {design.status}" + ("" if design.matters else " (the parameter does not "
                                                                                      "matter)"), fontsize=10)
    return _save(fig, fmt)
