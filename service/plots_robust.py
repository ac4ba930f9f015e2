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

from .plot_labels import TRANSLATIONAL, Units, path_label, path_scale
from .plots_simulation import MEDIA_TYPES

__all__ = ["plot_robust_slice", "robust_slice_figure", "plot_hardware", "hardware_figure", "MEDIA_TYPES",
           "margin_slice"]


def margin_slice(box: UncertaintyBox, stiffness: float, damping: float, worst: np.ndarray, x: str, y: str,
                 points: int = 41, render: tuple | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(xs, ys, margin[dB] of shape (len(ys), len(xs))) over the slice; −inf dB where K_cr = 0.  ``render``: a
    rendered wall's (velocity filter spec, virtual mass M [kg]), each K_cr by the exact rendered analysis."""
    i, j = box.paths.index(x), box.paths.index(y)
    u = np.linspace(0.0, 1.0, points)
    base = box.to_unit(worst)
    grid = np.repeat(base[None, :], points * points, axis=0)
    uu, vv = np.meshgrid(u, u)
    grid[:, i], grid[:, j] = uu.ravel(), vv.ravel()
    if render is None:
        kcr, _ = box_critical_stiffness(box, grid, damping)
    else:
        from optim.robust.rendered_stiffness import box_rendered_critical_stiffness

        kcr, _ = box_rendered_critical_stiffness(box, grid, damping, render[0], render[1])
    with np.errstate(divide="ignore"):
        margin = 20 * np.log10(kcr / stiffness)
    pts = box.to_box(grid)
    return pts[:points, i], pts[::points, j], margin.reshape(points, points)


def _save(fig: Figure, fmt: str) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format=fmt)
    return buf.getvalue()


def robust_slice_figure(xs, ys, margin, worst_xy, required_db: float, paths: tuple[str, str],
                        title: str | None = None, unit: Units = TRANSLATIONAL) -> Figure:
    """The margin over the (x, y) slice; ``paths`` are the box's dotted paths (labelled with their units,
    seconds shown in ms)."""
    fig = Figure(figsize=(7, 5.5), dpi=100)
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    sx, sy = path_scale(paths[0]), path_scale(paths[1])
    xs, ys, worst_xy = np.asarray(xs) * sx, np.asarray(ys) * sy, (worst_xy[0] * sx, worst_xy[1] * sy)
    finite = np.where(np.isfinite(margin), margin, np.nan)
    mesh = ax.pcolormesh(xs, ys, finite, shading="auto", cmap="viridis")
    fig.colorbar(mesh, ax=ax, label="gain margin [dB]")
    if np.nanmin(finite) < required_db + 3 and np.nanmax(finite) > required_db:
        ax.contour(xs, ys, finite, levels=[required_db], colors="w", linewidths=1.0)
    ax.plot([worst_xy[0]], [worst_xy[1]], marker="x", color="r", ms=12, mew=2.5, label="worst case")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_xlabel(path_label(paths[0], unit))
    ax.set_ylabel(path_label(paths[1], unit))
    ax.set_title(title or "robust design: margin over the box", fontsize=10)
    fig.tight_layout()
    return fig


def plot_robust_slice(xs, ys, margin, worst_xy, required_db: float, labels: tuple[str, str], fmt: str = "png",
                      title: str | None = None, unit: Units = TRANSLATIONAL) -> bytes:
    return _save(robust_slice_figure(xs, ys, margin, worst_xy, required_db, labels, title, unit), fmt)


def _hw_panels(unit: Units) -> dict[str, tuple[str, str, str]]:
    """target → (curve key, axis label, curve label); the target line is the target's own value."""
    return {
        "stiffness": ("achievable_stiffness", f"$K^*$ [{unit.stiffness}]", "achievable stiffness $K^*$"),
        "force_gain": ("achievable_force_gain", "$K_f^*$ [-]", "achievable force gain $K_f^*$"),
        "apparent_mass": ("apparent_mass", f"$m/(1 + K_f^*)$ [{unit.mass}]", "achievable apparent mass"),
    }


def plot_hardware(design: HardwareDesign, target: HardwareTarget, fmt: str = "png", title: str = "",
                  unit: Units = TRANSLATIONAL) -> bytes:
    return _save(hardware_figure(design, target, title, unit), fmt)


def hardware_figure(design: HardwareDesign, target: HardwareTarget, title: str = "",
                    unit: Units = TRANSLATIONAL) -> Figure:
    """One panel per target given (stiffness; force gain or apparent mass), sharing the free parameter's axis;
    ``title`` names the device (its first line)."""
    names = target.names
    panels = _hw_panels(unit)
    scale = path_scale(f"device.{design.free}")
    fig = Figure(figsize=(7, 3.2 + 2.3 * len(names)), dpi=100)
    FigureCanvasAgg(fig)
    axes = fig.subplots(len(names), 1, sharex=True, squeeze=False)[:, 0]
    q = np.array([p["value"] for p in design.curve]) * scale
    for ax, name in zip(axes, names):
        key, ylabel, label = panels[name]
        v = np.array([np.nan if p[key] is None else p[key] for p in design.curve], dtype=float)
        shown = np.where((v > 0) & np.isfinite(v), v, np.nan)
        ax.plot(q, shown, "-o", ms=3, lw=1.2, label=label)
        ax.axhline(getattr(target, name), color="tab:red", lw=1, ls="--", label="target")
        for lo, hi in design.intervals:
            ax.axvspan(lo * scale, hi * scale, color="tab:green", alpha=0.12)
        if design.value is not None:
            ax.axvline(design.value * scale, color="k", lw=1,
                       label=f"loosest {path_label(f'device.{design.free}', unit)} = {design.value * scale:.4g}")
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
    axes[-1].set_xlabel(path_label(f"device.{design.free}", unit))
    limit = f", limited by {design.limiting_target}" if design.limiting_target else ""
    head = f"{title}\n" if title else ""
    axes[0].set_title(head + f"hardware trade-off: {design.status}{limit}" + (
        "" if design.matters else " (the parameter does not matter)"), fontsize=10)
    fig.tight_layout()
    return fig
