"""Plot of a simulated scene: motor position, force and generated energy against time (matplotlib Agg).

A Figure with its own Agg canvas (no pyplot state), so concurrent requests don't share a figure.
"""

from __future__ import annotations

import io

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from models.device import Device
from models.simulation.scene import Scene
from models.simulation.simulate import SimulationResult

from .plot_labels import device_title, units

__all__ = ["plot_simulation", "simulation_figure", "left_out", "scene_line", "MEDIA_TYPES"]

MEDIA_TYPES = {"png": "image/png", "svg": "image/svg+xml"}


def plot_simulation(res: SimulationResult, fmt: str = "png", title: str | None = None,
                    device: Device | None = None, scene: Scene | None = None) -> bytes:
    buf = io.BytesIO()
    simulation_figure(res, title, device, scene).savefig(buf, format=fmt)
    return buf.getvalue()


#: a device block the scene left out -> its name on the figure
_LEFT_OUT = {"delay": "delay", "cable": "cable mode", "human": "hand", "force_sensor": "force-sensor filter"}


def left_out(res: SimulationResult) -> list[str]:
    """The device blocks the scene left out, in words ('delay', 'cable mode', 'hand', 'force-sensor filter')."""
    names = [n.split(":", 1)[0] for n in res.not_simulated]
    return [_LEFT_OUT.get(n, n) for n in names]


def scene_line(scene: Scene | None, device: Device | None) -> str:
    """'K = 3000 N/m, B = 0 N·s/m' (the wall), or 'relay h = 1 N' (the relay); '' without a scene."""
    if scene is None:
        return ""
    u = units(device)
    if scene.controller is not None:
        return f"K = {scene.controller.stiffness:.5g} {u.stiffness}, B = {scene.controller.damping:.4g} {u.damping}"
    if scene.relay is not None:
        return f"relay h = {scene.relay.amplitude:.4g} {'N·m' if u.stiffness != 'N/m' else 'N'}"
    return ""


def simulation_figure(res: SimulationResult, title: str | None = None, device: Device | None = None,
                      scene: Scene | None = None) -> Figure:
    """Position, force and generated energy; the title names the device (when given), the wall (K and B) or the
    relay of the scene (when given), the verdict, and the device blocks the scene left out (never silent).
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
    wall = scene_line(scene, device)
    out = left_out(res)
    said = f"not simulated: {', '.join(out)}" if out else "every block of the device simulated"
    fig.suptitle(title or f"{head}{wall + ': ' if wall else ''}{v.state} ({res.judgement.decided_by}){freq} — "
                 f"{res.method}\n{said}", fontsize=10)
    fig.tight_layout()
    return fig
