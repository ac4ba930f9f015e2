"""PNG and SVG figures of the stability boundary and of the loop's Bode diagram (headless matplotlib).

Figures are drawn from the numerics' own results (optim.stability.boundary.Boundary,
optim.stability.frequency_response.FrequencyResponse) without recomputing anything: the
plotted arrays are those objects' arrays.  ``matplotlib.figure.Figure`` is used
directly (no pyplot): no global figure registry, so concurrent requests in the
thread pool do not share state.
"""

from __future__ import annotations

import io
import math
from typing import TYPE_CHECKING, Literal, Sequence

import matplotlib

matplotlib.use("Agg")  # headless: no display, no GUI toolkit
# SVG element ids are random unless salted: a fixed salt makes equal requests give equal files.
matplotlib.rcParams["svg.hashsalt"] = "zwidth"

import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from optim.stability.boundary import Boundary  # noqa: E402
from optim.stability.frequency_response import FrequencyResponse  # noqa: E402

from .plot_labels import TRANSLATIONAL, Units, device_title, units  # noqa: E402

if TYPE_CHECKING:
    from optim.stability.frequency_response import CrossoverPoint as Crossover

__all__ = ["boundary_figure", "bode_figure", "render", "MEDIA_TYPES", "ImageFormat", "MAX_CROSSOVER_LABELS",
           "labelled_crossovers", "boundary_plot", "bode_plot"]

ImageFormat = Literal["png", "svg"]
MEDIA_TYPES: dict[str, str] = {"png": "image/png", "svg": "image/svg+xml"}
#: Crossovers labelled with their K_i on a Bode diagram: a text per crossover made a 10 s delay's thousands of
#: labels take a minute to draw (issue 18); the rest are marked and counted.
MAX_CROSSOVER_LABELS = 12


def labelled_crossovers(crossovers: Sequence[Crossover]) -> list[Crossover]:
    """The crossovers whose K_i is written on the figure: the MAX_CROSSOVER_LABELS of least K_i (the one that
    sets K_cr first), in frequency order."""
    keep = sorted(range(len(crossovers)), key=lambda i: (crossovers[i].stiffness, i))[:MAX_CROSSOVER_LABELS]
    return [crossovers[i] for i in sorted(keep)]


def boundary_figure(boundary: Boundary, title: str = "", unit: Units = TRANSLATIONAL) -> Figure:
    """K_cr(B) with eq. 10's linear estimate beside it and the optimum marked (chapter Fig. 5/9)."""
    k_u, b_u = unit.stiffness, unit.damping
    fig = Figure(figsize=(6.4, 4.4), dpi=100)
    ax = fig.add_subplot()
    b = np.array([p.damping for p in boundary.points])
    k = np.array([p.critical_stiffness for p in boundary.points], dtype=float)  # NaN where every K is stable
    lin = np.array([p.linear_estimate for p in boundary.points])
    ax.plot(b, k, "-", color="C0", label="exact $K_{cr}(B)$", gid="boundary")
    ax.plot(b, lin, "--", color="C7", label="linear estimate (eq. 10)", gid="linear")
    best = boundary.optimum
    ax.plot([best.damping], [best.critical_stiffness], "o", color="C3", gid="optimum",
            label=f"optimum B = {best.damping:.4g} {b_u}, K = {best.critical_stiffness:.5g} {k_u}")
    if boundary.max_stable_damping is not None:
        ax.axvline(boundary.max_stable_damping, color="C1", lw=0.8, ls=":", gid="b_max",
                   label=f"B_max = {boundary.max_stable_damping:.4g} {b_u}")
    finite = k[np.isfinite(k)]
    top = max(float(finite.max()) if finite.size else 1.0, best.critical_stiffness)
    ax.set_ylim(0.0, 1.15 * top)
    ax.set_xlabel(f"virtual damping B [{b_u}]")
    ax.set_ylabel(f"critical stiffness $K_{{cr}}$ [{k_u}]")
    ax.set_title(title or "Stability boundary", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small")
    # Fixed margins: tight_layout would draw the figure once more just to measure it (half the cost).
    fig.subplots_adjust(left=0.14, right=0.97, bottom=0.12, top=0.93)
    return fig


#: The sampled loop in mathtext: Z-transform of hold, plant and delay.
LOOP_MATH = r"$\mathcal{Z}[H\,G_r\,e^{-t_d s}]$"


def _label_offset(ax, x: float, y: float) -> tuple[tuple[float, float], str, str]:
    """An offset and alignment that keep a point's label inside the axes (right of and above the point, unless
    the point is in the right or top fifth of the view)."""
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    fx = (math.log10(x) - math.log10(x0)) / (math.log10(x1) - math.log10(x0)) if x > 0 and x0 > 0 else 0.5
    fy = (y - y0) / (y1 - y0) if y1 > y0 else 0.5
    right, top = fx > 0.8, fy > 0.8
    return ((-4 if right else 4), (-6 if top else 6)), ("right" if right else "left"), ("top" if top else "bottom")


def bode_figure(response: FrequencyResponse, stiffness: float | None = None, title: str = "",
                unit: Units = TRANSLATIONAL) -> Figure:
    """|G(e^{jωT})| [dB re 1 m/N] and its phase [deg], the crossovers of K_cr(B) marked."""
    k_u = unit.stiffness
    g_u = "rad/(N·m)" if unit.stiffness != "N/m" else "m/N"
    fig = Figure(figsize=(6.4, 6.0), dpi=100)
    ax_m, ax_p = fig.subplots(2, 1, sharex=True)
    w = response.frequency
    with np.errstate(divide="ignore"):  # an exact zero of G (undamped anti-resonance) plots as a gap
        db = 20 * np.log10(response.magnitude)
    ax_m.semilogx(w, db, color="C0", gid="magnitude", label=r"$|G(e^{j\omega T})|$")
    ax_p.semilogx(w, response.phase_deg, color="C0", gid="phase")
    crossovers = response.crossovers
    if crossovers:
        # One line artist for all crossovers (a long delay has thousands), labels on the binding few only.
        f = np.array([c.frequency for c in crossovers])
        ax_m.plot(f, [20 * math.log10(c.magnitude) for c in crossovers], "o", color="C3", ms=4, gid="crossovers",
                  label="crossovers ($K_i = 1/|G|$)")
        ax_p.plot(f, [c.phase_deg for c in crossovers], "o", color="C3", ms=4, gid="crossovers-phase")
        ax_m.autoscale_view()   # the limits the labels are placed against
        for c in labelled_crossovers(crossovers):
            xy = (c.frequency, 20 * math.log10(c.magnitude))
            off, ha, va = _label_offset(ax_m, *xy)
            ax_m.annotate(f"{c.stiffness:.4g} {k_u}", xy, textcoords="offset points", xytext=off, ha=ha, va=va,
                          fontsize="x-small", gid="crossover-label")
        if len(crossovers) > MAX_CROSSOVER_LABELS:
            ax_m.text(0.01, 0.02, f"{len(crossovers)} crossovers; the {MAX_CROSSOVER_LABELS} of least K labelled",
                      transform=ax_m.transAxes, fontsize="x-small", color="C3", gid="crossover-summary")
    if stiffness is not None and response.damping == 0.0:
        # With B = 0 the gain margin is the gap between 1/K and |G| at the crossover that sets K_cr.
        ax_m.axhline(-20 * math.log10(stiffness), color="C2", ls="--", lw=0.8, gid="wall",
                     label=f"1/K, K = {stiffness:.4g} {k_u}")
    ax_p.axhline(-180.0, color="C7", lw=0.6)
    ax_m.axvline(response.nyquist_frequency, color="C7", lw=0.6, ls=":")
    ax_m.set_ylabel(f"|G| [dB re 1 {g_u}]")
    ax_p.set_ylabel("phase [deg]")
    ax_p.set_xlabel("ω [rad/s]")
    ax_m.set_title(title or f"Sampled loop {LOOP_MATH}", fontsize=10)
    for ax in (ax_m, ax_p):
        ax.grid(True, which="major", alpha=0.3)
    ax_m.legend(fontsize="small")
    fig.subplots_adjust(left=0.14, right=0.97, bottom=0.09, top=0.92, hspace=0.08)
    return fig


def render(fig: Figure, fmt: ImageFormat) -> bytes:
    """The figure as PNG or SVG bytes (SVG without a date, so equal inputs give equal files)."""
    if fmt not in MEDIA_TYPES:
        raise ValueError(f"format: must be one of {', '.join(MEDIA_TYPES)}")
    buf = io.BytesIO()
    metadata = {"Date": None} if fmt == "svg" else {"Software": None}
    fig.savefig(buf, format=fmt, metadata=metadata)
    return buf.getvalue()


def boundary_plot(device, damping_max: float | None, points: int, fmt: ImageFormat, rendering=None) -> bytes:
    """Compute and draw the boundary figure: what a compute worker runs for /v1/plots/boundary (the drawing is
    under the request time budget too, and the server process never holds a figure).  ``rendering``: the walls'
    velocity filter and virtual mass (models.velocity_filter.Rendering; None: today's wall)."""
    from optim.stability.boundary import stability_boundary

    title = f"Stability boundary: {device_title(device)}"
    if rendering is not None:
        title += f"\n{rendering_title(rendering)}"
    return render(boundary_figure(stability_boundary(device, damping_max, points, rendering), title, units(device)),
                  fmt)


def rendering_title(rendering) -> str:
    """The rendered wall in a title: its velocity filter and virtual mass."""
    spec = rendering.spec
    kind = getattr(spec, "kind", None) or rendering.velocity.kind
    parts = [kind.replace("_", " ")]
    if getattr(spec, "cutoff_hz", None) is not None:
        parts[0] += f" {spec.cutoff_hz:g} Hz, order {spec.order}"
    elif getattr(spec, "samples", None) is not None:
        parts[0] += f" of {spec.samples} samples"
    if rendering.mass:
        parts.append(f"virtual mass M = {rendering.mass:g}")
    return "velocity filter: " + "; ".join(parts)


def bode_plot(device, damping: float, points: int, stiffness: float | None, fmt: ImageFormat) -> bytes:
    """Compute and draw the Bode figure: what a compute worker runs for /v1/plots/bode."""
    from optim.stability.frequency_response import loop_frequency_response

    title = f"{LOOP_MATH}, B = {damping:.4g} {units(device).damping}\n{device_title(device)}"
    return render(bode_figure(loop_frequency_response(device, damping, points), stiffness, title, units(device)), fmt)
