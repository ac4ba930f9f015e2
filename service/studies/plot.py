"""A study's result against one swept parameter (line) or two (heatmap), PNG or SVG (matplotlib Agg)."""

from __future__ import annotations

import io
import math
from typing import Any, Sequence

from optim.errors import InputError

__all__ = ["plot_rows", "plot_study"]


def _finite(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _log_ok(values: Sequence[float], log: bool | None = None) -> bool:
    """Log axis when the sweep says so (a log range), else when positive values span more than a decade."""
    if not values or min(values) <= 0:
        return False
    return log if log is not None else max(values) / min(values) > 10


def plot_rows(rows: Sequence[dict[str, Any]], y: str, x: str, x2: str | None, fmt: str, title: str,
              log_paths: dict[str, bool] | None = None) -> bytes:
    """``log_paths``: swept path -> True for a log range, False for a linear one (value lists: by span)."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    pts = [(r[x], r[x2] if x2 else 0.0, r.get(y)) for r in rows if _finite(r.get(x)) and (x2 is None or _finite(r.get(x2)))]
    fig = Figure(figsize=(7, 4.5), dpi=100)
    ax = fig.add_subplot()
    if x2 is None:
        good = sorted((a, c) for a, _, c in pts if _finite(c))
        xs, ys = [p[0] for p in good], [p[1] for p in good]
        unique = len(set(xs)) == len(xs)
        ax.plot(xs, ys, "-o" if unique else "o", ms=3)
        ax.set_ylabel(y)
        if _log_ok(xs, (log_paths or {}).get(x)):
            ax.set_xscale("log")
    else:
        xs, ys, zs = zip(*[(a, b, c) for a, b, c in pts if _finite(c)]) if any(_finite(c) for *_, c in pts) else ((), (), ())
        ux, uy = sorted(set(xs)), sorted(set(ys))
        from matplotlib.colors import LogNorm

        # a result spanning orders of magnitude (K_cr over delay) reads on a log colour scale
        norm = LogNorm() if zs and min(zs) > 0 and max(zs) / min(zs) > 100 else None
        if len(ux) * len(uy) == len(xs) and len(ux) > 1 and len(uy) > 1:  # a full grid: a heatmap
            import numpy as np

            grid = np.full((len(uy), len(ux)), np.nan)
            ix, iy = {v: i for i, v in enumerate(ux)}, {v: i for i, v in enumerate(uy)}
            for a, b, c in zip(xs, ys, zs):
                grid[iy[b], ix[a]] = c
            mesh = ax.pcolormesh(ux, uy, grid, shading="nearest", norm=norm)
        else:  # scattered samples (a Latin hypercube, or other swept parameters)
            mesh = ax.scatter(xs, ys, c=zs, s=12, norm=norm)
        fig.colorbar(mesh, ax=ax, label=y)
        ax.set_ylabel(x2)
        if _log_ok(list(xs), (log_paths or {}).get(x)):
            ax.set_xscale("log")
        if _log_ok(list(ys), (log_paths or {}).get(x2)):
            ax.set_yscale("log")
    ax.set_xlabel(x)
    ax.set_title(title, fontsize=10)
    ax.grid(True, alpha=0.3)
    buf = io.BytesIO()
    fig.savefig(buf, format=fmt, bbox_inches="tight")
    return buf.getvalue()


_stores: dict[str, Any] = {}


def plot_study(url: str, study_id: str, paths: list[str], y: str, x: str, x2: str | None, fmt: str, title: str,
               log_paths: dict[str, bool]) -> bytes:
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
    return plot_rows(rows, y, x, x2, fmt, title, log_paths)
