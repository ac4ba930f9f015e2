"""A study's result against one swept parameter (line) or two (heatmap), PNG or SVG (matplotlib Agg)."""

from __future__ import annotations

import io
import math
from typing import Any, Sequence

from optim.errors import InputError

__all__ = ["plot_rows", "plot_study", "study_figure", "MAX_VALUE_TICKS"]


def _finite(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _log_ok(values: Sequence[float], log: bool | None = None) -> bool:
    """Log axis when the sweep says so (a log range), else when positive values span more than a decade."""
    if not values or min(values) <= 0:
        return False
    return log if log is not None else max(values) / min(values) > 10


#: At most this many distinct swept values get a tick each (more would overlap): the rest keep matplotlib's ticks.
MAX_VALUE_TICKS = 12


def _edges(values: Sequence[float], log: bool) -> list[float]:
    """Cell edges of sorted values: midpoints between neighbours (geometric on a log axis), the ends mirrored,
    so each cell sits at its true value however uneven the sweep."""
    import numpy as np

    v = np.log10(values) if log else np.asarray(values, float)
    mid = (v[1:] + v[:-1]) / 2
    e = np.concatenate([[v[0] - (mid[0] - v[0])], mid, [v[-1] + (v[-1] - mid[-1])]])
    return list(10 ** e if log else e)


def _value_ticks(axis, values: Sequence[float]) -> None:
    """Ticks at the swept values themselves when there are few of them."""
    if 1 < len(values) <= MAX_VALUE_TICKS:
        from matplotlib.ticker import NullLocator

        axis.set_ticks(list(values), [f"{v:.4g}" for v in values])
        axis.set_minor_locator(NullLocator())


def study_figure(rows: Sequence[dict[str, Any]], y: str, x: str, x2: str | None, title: str,
                 log_paths: dict[str, bool] | None = None, device: dict[str, Any] | None = None):
    """The figure of plot_rows: axes labelled with the swept paths' names and units (seconds in ms), a heatmap's
    cells at their true values, ticks at the swept values when they are few; ``device`` is the study's base
    device (its units: N/m or N·m/rad)."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    from ..plot_labels import path_label, path_scale, result_label

    log_paths = log_paths or {}
    sx, sy = path_scale(x), path_scale(x2) if x2 else 1.0
    pts = [(r[x] * sx, r[x2] * sy if x2 else 0.0, r.get(y)) for r in rows
           if _finite(r.get(x)) and (x2 is None or _finite(r.get(x2)))]
    fig = Figure(figsize=(7, 4.5), dpi=100)
    ax = fig.add_subplot()
    ylabel = result_label(y, device)
    if x2 is None:
        good = sorted((a, c) for a, _, c in pts if _finite(c))
        xs, ys = [p[0] for p in good], [p[1] for p in good]
        unique = len(set(xs)) == len(xs)
        ax.plot(xs, ys, "-o" if unique else "o", ms=3)
        ax.set_ylabel(ylabel)
        if _log_ok(xs, log_paths.get(x)):
            ax.set_xscale("log")
        _value_ticks(ax.xaxis, sorted(set(xs)))
    else:
        xs, ys, zs = zip(*[(a, b, c) for a, b, c in pts if _finite(c)]) if any(_finite(c) for *_, c in pts) else ((), (), ())
        ux, uy = sorted(set(xs)), sorted(set(ys))
        from matplotlib.colors import LogNorm

        # a result spanning orders of magnitude (K_cr over delay) reads on a log colour scale
        norm = LogNorm() if zs and min(zs) > 0 and max(zs) / min(zs) > 100 else None
        logx, logy = _log_ok(list(xs), log_paths.get(x)), _log_ok(list(ys), log_paths.get(x2))
        if len(ux) * len(uy) == len(xs) and len(ux) > 1 and len(uy) > 1:  # a full grid: a heatmap
            import numpy as np

            grid = np.full((len(uy), len(ux)), np.nan)
            ix, iy = {v: i for i, v in enumerate(ux)}, {v: i for i, v in enumerate(uy)}
            for a, b, c in zip(xs, ys, zs):
                grid[iy[b], ix[a]] = c
            mesh = ax.pcolormesh(_edges(ux, logx), _edges(uy, logy), grid, shading="flat", norm=norm)
            full = True
        else:  # scattered samples (a Latin hypercube, or other swept parameters)
            mesh = ax.scatter(xs, ys, c=zs, s=12, norm=norm)
            full = False
        fig.colorbar(mesh, ax=ax, label=ylabel)
        ax.set_ylabel(path_label(x2, device))
        if logx:
            ax.set_xscale("log")
        if logy:
            ax.set_yscale("log")
        if full:
            _value_ticks(ax.xaxis, ux)
            _value_ticks(ax.yaxis, uy)
    ax.set_xlabel(path_label(x, device))
    ax.set_title(title, fontsize=10)
    ax.grid(True, alpha=0.3)
    if any(len(t.get_text()) > 6 for t in ax.get_xticklabels()):
        ax.tick_params(axis="x", labelrotation=30)
    fig.tight_layout()
    return fig


def plot_rows(rows: Sequence[dict[str, Any]], y: str, x: str, x2: str | None, fmt: str, title: str,
              log_paths: dict[str, bool] | None = None, device: dict[str, Any] | None = None) -> bytes:
    """``log_paths``: swept path -> True for a log range, False for a linear one (value lists: by span)."""
    buf = io.BytesIO()
    study_figure(rows, y, x, x2, title, log_paths, device).savefig(buf, format=fmt)
    return buf.getvalue()


_stores: dict[str, Any] = {}


def plot_study(url: str, study_id: str, paths: list[str], y: str, x: str, x2: str | None, fmt: str, title: str,
               log_paths: dict[str, bool], device: dict[str, Any] | None = None) -> bytes:
    """Read the study's results from the store at ``url`` and draw them: what a compute worker runs for
    GET /v1/studies/{id}/plot, so the rows and the figure never sit in the server process and the drawing is
    under the request time budget.  InputError on ``y`` when it is not a result of the study."""
    from .export import columns, flat_row
    from .store import StudyStore

    store = _stores.get(url)
    if store is None:   # one engine per worker process and store
        store = _stores[url] = StudyStore(url)
    rows = [flat_row(paths, r) for r in store.iter_results(study_id)]
    if rows and not any(y in r for r in rows):
        known = [c for c in columns(paths, rows) if c not in ("index", "error", *paths)]
        raise InputError("y", f"{y!r} is not a result of this study; results: {', '.join(known)}")
    return plot_rows(rows, y, x, x2, fmt, title, log_paths, device)
