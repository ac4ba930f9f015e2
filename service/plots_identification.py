"""Plot of an identification: measured against fitted with the residual (time series: position over time;
frequency response: Bode magnitude and phase).  A Figure with its own Agg canvas (no pyplot state)."""

from __future__ import annotations

import io

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from optim.identification import IdentificationResult

__all__ = ["MEDIA_TYPES", "plot_identification", "identification_figure", "identified_title"]

MEDIA_TYPES = {"png": "image/png", "svg": "image/svg+xml"}


def _message(fig: Figure, text: str) -> None:
    ax = fig.subplots()
    ax.axis("off")
    ax.text(0.5, 0.5, text, ha="center", va="center", wrap=True, fontsize=10)


def identified_title(res: IdentificationResult, sample_time: float | None) -> str:
    """The identified device as the other plots name one: m, b (and k_c), rigid or cable, t_d and T."""
    d = res.device or {}
    cable = d.get("cable") or {}
    parts = [f"{sym} = {v:.4g} {u}" for v, sym, u in ((d.get("mass"), "m", "kg"), (d.get("damping"), "b", "N·s/m"),
                                                       (cable.get("stiffness"), "k_c", "N/m")) if v is not None]
    head = ", ".join(parts) or "identified device"
    tail = "".join(f", {sym} = {v * 1e3:.4g} ms" for sym, v in (("t_d", d.get("delay")),
                                                                ("T", d.get("sample_time", sample_time)))
                   if v is not None)
    return f"{head} ({res.model}){tail}"


def plot_identification(res: IdentificationResult, fmt: str = "png", sample_time: float | None = None) -> bytes:
    buf = io.BytesIO()
    identification_figure(res, sample_time).savefig(buf, format=fmt)
    return buf.getvalue()


def identification_figure(res: IdentificationResult, sample_time: float | None = None) -> Figure:
    """Measured against fitted with the residual; the title names the identified device and the fit."""
    fig = Figure(figsize=(8, 6.5), dpi=100)
    FigureCanvasAgg(fig)
    cur = res.fitted
    if res.status == "failed" or cur is None:
        _message(fig, f"identification failed:\n{res.reason}")
    elif cur["kind"] == "time_series":
        ax1, ax2 = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [2, 1]})
        t, y, f = cur["x"], cur["measured"], cur["fitted"]
        ax1.plot(t, y * 1e3, lw=0.8, label="measured")
        ax1.plot(t, f * 1e3, lw=0.8, ls="--", label=f"fitted ({res.model})")
        ax1.set_ylabel("position [mm]")
        ax1.legend(loc="best", fontsize=8)
        ax2.plot(t, (y - f) * 1e6, lw=0.6, color="tab:red")
        ax2.set_ylabel("residual [µm]")
        ax2.set_xlabel("time [s]")
    else:
        ax1, ax2, ax3 = fig.subplots(3, 1, sharex=True, gridspec_kw={"height_ratios": [2, 2, 1]})
        w, h, g = cur["x"], cur["measured"], cur["fitted"]
        o = np.argsort(w)
        ax1.loglog(w[o], np.abs(h[o]), ".", ms=4, label="measured")
        ax1.loglog(w[o], np.abs(g[o]), lw=1.0, label=f"fitted ({res.model})")
        ax1.set_ylabel("|X/F| [m/N]")
        ax1.legend(loc="best", fontsize=8)
        ax2.semilogx(w[o], np.degrees(np.unwrap(np.angle(h[o]))), ".", ms=4)
        ax2.semilogx(w[o], np.degrees(np.unwrap(np.angle(g[o]))), lw=1.0)
        ax2.set_ylabel("phase [deg]")
        ax3.semilogx(w[o], np.abs((h[o] - g[o]) / h[o]) * 100, ".", ms=4, color="tab:red")
        ax3.set_ylabel("|error| [%]")
        ax3.set_xlabel("ω [rad/s]")
    if res.status != "failed" and res.fit is not None:
        fig.suptitle(f"{identified_title(res, sample_time)}\nNRMSE {res.fit.nrmse:.3g}, Ljung–Box p = "
                     f"{res.fit.residual_whiteness['p_value']:.2g}", fontsize=10)
    fig.tight_layout()
    return fig
