"""Plot of a simulated scene: motor position, force and generated energy against time (matplotlib Agg).

A Figure with its own Agg canvas (no pyplot state), so concurrent requests don't share a figure.
"""

from __future__ import annotations

import io

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from models.device import Device
from models.simulation.simulate import SimulationResult

from .plot_labels import device_title

__all__ = ["plot_simulation", "simulation_figure", "MEDIA_TYPES"]

MEDIA_TYPES = {"png": "image/png", "svg": "image/svg+xml"}


def plot_simulation(res: SimulationResult, fmt: str = "png", title: str | None = None,
                    device: Device | None = None) -> bytes:
    buf = io.BytesIO()
    simulation_figure(res, title, device).savefig(buf, format=fmt)
    return buf.getvalue()


def simulation_figure(res: SimulationResult, title: str | None = None, device: Device | None = None) -> Figure:
    """Position, force and generated energy; the title names the device (when given) and the verdict.
    The position is the motor's x_r (for a rotary device an angle: shown in mrad)."""
    tr = res.trajectory
    rotary = device is not None and device.rotary
    fig = Figure(figsize=(8, 6.5), dpi=100)
    FigureCanvasAgg(fig)
    ax1, ax2, ax3 = fig.subplots(3, 1, sharex=True)
    ax1.plot(tr.time, tr.motor_position * 1e3, lw=0.8, label="motor x_r")
    if res.effects_simulated and "cable_mode" in res.effects_simulated:
        ax1.plot(tr.time, tr.body_position * 1e3, lw=0.8, label="body x_d")
        ax1.legend(loc="upper right", fontsize=8)
    ax1.set_ylabel("angle [mrad]" if rotary else "position [mm]")
    ax2.plot(tr.time, tr.force, lw=0.8, color="tab:red")
    ax2.set_ylabel("torque [N·m]" if rotary else "force [N]")
    ax3.plot(tr.time, tr.energy_generated, lw=0.8, color="tab:green")
    ax3.set_ylabel("E generated [J]")
    ax3.set_xlabel("time [s]")
    v = res.verdict
    freq = f", ω = {v.frequency:.4g} rad/s" if v.frequency else ""
    head = f"{device_title(device)}\n" if device is not None else ""
    fig.suptitle(title or f"{head}{v.state} ({res.judgement.decided_by}){freq} — {res.method}", fontsize=10)
    fig.tight_layout()
    return fig
