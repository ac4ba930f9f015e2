"""A study's result against one swept parameter (line) or two (heatmap), PNG or SVG (matplotlib Agg)."""

from __future__ import annotations

import io
import math
from typing import Any, Sequence

from optim.errors import InputError

__all__ = ["plot_rows", "plot_study", "study_figure", "check_y", "MAX_VALUE_TICKS"]


def _finite(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _key(v: Any) -> Any:
    """A swept value as a grouping key (a float, or its text when it is not a number)."""
    return float(v) if _finite(v) else str(v)


def _sort_key(key: tuple) -> tuple:
    return tuple((0, v, "") if isinstance(v, float) else (1, 0.0, v) for v in key)


def _log_ok(values: Sequence[float], log: bool | None = None) -> bool:
    """Log axis when the sweep says so (a log range), else when positive values span more than a decade."""
    if not values or min(values) <= 0:
        return False
    return log if log is not None else max(values) / min(values) > 10


#: At most this many distinct swept values get a tick each (more would overlap): the rest keep matplotlib's ticks.
MAX_VALUE_TICKS = 12
#: At most this many series on a line plot (one per value of the other swept paths), each with its legend entry;
#: more are drawn as points coloured by the first other path.
MAX_SERIES = 12


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
                 log_paths: dict[str, bool] | None = None, device: dict[str, Any] | None = None,
                 paths: Sequence[str] | None = None):
    """The figure of plot_rows: axes labelled with the swept paths' names and units (seconds in ms), a heatmap's
    cells at their true values, ticks at the swept values when they are few; ``device`` is the study's base
    device (its units: N/m or N·m/rad).  ``paths`` are the study's swept paths: a line plot draws one series per
    value of the swept paths other than ``x`` (distinct colours, markers and lines, with a legend)."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    from ..plot_labels import path_label, path_scale, path_value, result_label

    log_paths = log_paths or {}
    sx, sy = path_scale(x), path_scale(x2) if x2 else 1.0
    pts = [(r[x] * sx, r[x2] * sy if x2 else 0.0, r.get(y)) for r in rows
           if _finite(r.get(x)) and (x2 is None or _finite(r.get(x2)))]
    fig = Figure(figsize=(7, 4.5), dpi=100)
    ax = fig.add_subplot()
    ylabel = result_label(y, device)
    if x2 is None:
        # One series per value of the other swept paths (a line through one x each), told apart by colour,
        # marker and line style, with a legend saying which values they hold.
        others = [p for p in (paths or ()) if p not in (x, y) and len({_key(r.get(p)) for r in rows}) > 1]
        groups: dict[tuple, list[tuple[float, float]]] = {}
        for r in rows:
            if _finite(r.get(x)) and _finite(r.get(y)):
                groups.setdefault(tuple(_key(r.get(p)) for p in others), []).append((r[x] * sx, r[y]))
        all_x = sorted({a for g in groups.values() for a, _ in g})
        styles = ("-", "--", "-.", ":")
        markers = ("o", "s", "^", "D", "v", "P", "X", "*")
        if len(groups) > MAX_SERIES:   # too many to tell apart (a Latin hypercube): points coloured by the first
            pts1 = [(r[x] * sx, r[y], r.get(others[0])) for r in rows if _finite(r.get(x)) and _finite(r.get(y))]
            numeric = all(_finite(c) for *_, c in pts1)
            sc = ax.scatter([a for a, _, _ in pts1], [b for _, b, _ in pts1], s=12,
                            c=[c * path_scale(others[0]) for *_, c in pts1] if numeric else "C0")
            if numeric:
                fig.colorbar(sc, ax=ax, label=path_label(others[0], device))
            groups = {}
        for k, key in enumerate(sorted(groups, key=_sort_key)):
            good = sorted(groups[key])
            label = ", ".join(path_value(p, v, device) if isinstance(v, (int, float)) else f"{path_label(p, device)}"
                              f" = {v}" for p, v in zip(others, key)) or None
            ax.plot([a for a, _ in good], [c for _, c in good], linestyle=styles[k % len(styles)],
                    marker=markers[k % len(markers)], ms=4, color=f"C{k % 10}", label=label)
        if others and groups and len(groups) > 1:
            ax.legend(fontsize=7 if len(groups) > 6 else 8, ncol=2 if len(groups) > 8 else 1,
                      title=", ".join(path_label(p, device) for p in others), title_fontsize=7)
        ax.set_ylabel(ylabel)
        if _log_ok(all_x, log_paths.get(x)):
            ax.set_xscale("log")
        _value_ticks(ax.xaxis, all_x)
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
              log_paths: dict[str, bool] | None = None, device: dict[str, Any] | None = None,
              paths: Sequence[str] | None = None) -> bytes:
    """``log_paths``: swept path -> True for a log range, False for a linear one (value lists: by span)."""
    buf = io.BytesIO()
    study_figure(rows, y, x, x2, title, log_paths, device, paths).savefig(buf, format=fmt)
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
    check_y(rows, y, [c for c in columns(paths, rows) if c not in ("index", "error", *paths)] if rows else [])
    return plot_rows(rows, y, x, x2, fmt, title, log_paths, device, paths)


def check_y(rows: Sequence[dict[str, Any]], y: str, results: Sequence[str]) -> None:
    """InputError on ``y`` when it is not a result of the study, or a result that is not a number (text or a
    yes/no: nothing to draw on a numeric axis).  ``results`` are the study's result columns."""
    if not rows:
        return
    if not any(y in r for r in rows):
        raise InputError("y", f"{y!r} is not a result of this study; results: {', '.join(results)}")
    if any(_finite(r.get(y)) for r in rows):
        return
    numeric = ", ".join(c for c in results if any(_finite(r.get(c)) for r in rows)) or "none"
    values = {r.get(y) for r in rows if not isinstance(r.get(y), float)}   # NaN is no number either
    if any(isinstance(v, bool) for v in values):
        what = "is yes/no, not a number"
    elif any(isinstance(v, str) for v in values):
        what = "is text, not a number"
    else:
        what = "holds no number at any point of this study (null at every point)"
    raise InputError("y", f"{y!r} {what}: a plot needs a numeric result; numeric results: {numeric}")
