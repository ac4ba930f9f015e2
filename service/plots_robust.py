"""Plots of robust and inverse designs (matplotlib Agg, a Figure per call: no shared pyplot state).

* robust: the margin 20·log10(K_cr(B; p)/K) over a two-parameter slice of the box (the other uncertain
  parameters at the worst device's values), worst device marked;
* hardware: the trade-off curves K*(q) and/or K_f*(q) (or the apparent mass), one panel per target, with
  the targets and the loosest value marked.
"""

from __future__ import annotations

import io

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from optim.hardware.design import HardwareDesign, HardwareTarget
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


#: target → (curve key, axis label, curve label); the target line is the target's own value
_HW_PANELS = {
    "stiffness": ("achievable_stiffness", "K* [N/m]", "achievable stiffness K*"),
    "force_gain": ("achievable_force_gain", "K_f* [-]", "achievable force gain K_f*"),
    "apparent_mass": ("apparent_mass", "m/(1 + K_f*) [kg]", "achievable apparent mass"),
}


def plot_hardware(design: HardwareDesign, target: HardwareTarget, fmt: str = "png") -> bytes:
    """One panel per target given (stiffness; force gain or apparent mass), sharing the free parameter's axis."""
    names = target.names
    fig = Figure(figsize=(7, 3.2 + 2.3 * len(names)), dpi=100)
    FigureCanvasAgg(fig)
    axes = fig.subplots(len(names), 1, sharex=True, squeeze=False)[:, 0]
    q = np.array([p["value"] for p in design.curve])
    for ax, name in zip(axes, names):
        key, ylabel, label = _HW_PANELS[name]
        v = np.array([np.nan if p[key] is None else p[key] for p in design.curve], dtype=float)
        shown = np.where((v > 0) & np.isfinite(v), v, np.nan)
        ax.plot(q, shown, "-o", ms=3, lw=1.2, label=label)
        ax.axhline(getattr(target, name), color="tab:red", lw=1, ls="--", label="target")
        for lo, hi in design.intervals:
            ax.axvspan(lo, hi, color="tab:green", alpha=0.12)
        if design.value is not None:
            ax.axvline(design.value, color="k", lw=1, label=f"loosest {design.free} = {design.value:.4g}")
        positive = shown[np.isfinite(shown)]   # empty when no design was scanned or none is stable
        if positive.size and positive.max() / positive.min() > 20:
            ax.set_yscale("log")
        ax.set_ylabel(ylabel)
        ax.legend(fontsize=8)
    if q.size and q.min() > 0 and q.max() / q.min() > 20:
        axes[-1].set_xscale("log")
    if not design.curve and design.reason:
        axes[0].text(0.5, 0.5, design.reason, transform=axes[0].transAxes, ha="center", va="center", wrap=True,
                     fontsize=8)
    axes[-1].set_xlabel(design.free)
    limit = f", limited by {design.limiting_target}" if design.limiting_target else ""
    axes[0].set_title(f"hardware trade-off: {design.status}{limit}" + (
        "" if design.matters else " (the parameter does not matter)"), fontsize=10)
    return _save(fig, fmt)
