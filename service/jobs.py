"""What a compute worker runs for a route that needs more than one numerics call (service.executor).

Each job is a module-level function of validated inputs (devices, frozen dataclasses, plain numbers), so
that it pickles by reference, and returns a picklable result: the numerics' frozen dataclasses or bytes.
CasADi solvers are never sent: the design code builds and caches its own in each worker process.  A job
raises what the numerics raise (InputError(field, rule), which answers 422 by itself); the route maps the rest.
A route with a single numerics call passes that function to ``Compute.run`` directly.
"""

from __future__ import annotations

import dataclasses

from models.device import Device
from models.filters import ButterworthLowPass
from models.simulation.scene import Scene
from models.simulation.simulate import SimulationResult, simulate
from optim.hardware.design import HardwareTarget, design_hardware
from optim.relay.experiment import RelayReport, relay_experiment
from optim.robust.box import UncertaintyBox
from optim.robust.stiffness import robust_design_stiffness
from optim.scene_verdict import with_margin_verdict
from optim.stiffness import StiffnessRequirements
from optim.transparency.feedforward import critical_force_gain
from optim.transparency.feedforward_ladder import ForceFeedforwardAnalysis, analyse_force_feedforward

from .errors import NumericInputError
from .plot_labels import device_title, units
from .plots_robust import margin_slice, plot_hardware, plot_robust_slice
from .plots_simulation import plot_simulation

__all__ = ["force_feedforward_job", "simulate_job", "robust_slice_job", "hardware_plot_job", "simulation_plot_job",
           "identify_plot_job"]


def force_feedforward_job(device: Device, filt: ButterworthLowPass | None, method: str,
                          grid_points: int) -> tuple[ForceFeedforwardAnalysis, float | None]:
    """The rung's K_f,cr analysis and, for a cable device on the exact or reference rung, what the rigid
    model claims (its cost stays out of the cheaper rungs)."""
    res = analyse_force_feedforward(device, filt, method=method, grid_points=grid_points)
    rigid = (critical_force_gain(device.rigid(), filt, res.human).critical_force_gain
             if device.cable and method in ("exact", "reference") else None)
    return res, rigid


def simulate_job(device: Device, scene: Scene) -> tuple[SimulationResult, RelayReport | None]:
    """Simulate the scene and, for a relay, read it like a lab.  The per-sample record (large, never
    serialised) is dropped before the result travels back from the worker."""
    result = with_margin_verdict(device, scene, simulate(device, scene))
    relay = relay_experiment(device, scene, result) if scene.experiment == "relay" else None
    return dataclasses.replace(result, record=None), relay


def robust_slice_job(device: Device, requirements: StiffnessRequirements, box: UncertaintyBox, x: str, y: str,
                     points: int, min_gain_margin_db: float, fmt: str, render: tuple | None = None) -> bytes:
    """The robust design and the figure of the margin over its (x, y) slice through the worst device (``render``: a
    rendered wall's (velocity filter spec, virtual mass M [kg]): optim.robust.rendered_stiffness and its K_cr)."""
    if render is None:
        design = robust_design_stiffness(device, requirements, box)
    else:
        from optim.robust.rendered_stiffness import robust_rendered_stiffness

        design = robust_rendered_stiffness(device, requirements, box, render[1], render[0])
    if design.status != "optimal":
        raise NumericInputError("requirements", f"no robust design to plot: {design.status}: {design.reason}")
    paths = list(box.paths)
    worst = box.to_box(box.to_unit(list(design.worst_case["device"].values())))
    xs, ys, margin = margin_slice(box, design.stiffness, design.damping, worst, x, y, points, render)
    wxy = (worst[paths.index(x)], worst[paths.index(y)])
    u = units(device)
    ranges = {p: (float(lo), float(hi)) for p, lo, hi in zip(box.paths, box.lower, box.upper)}
    title = (f"{device_title(device, ranges)}\nK = {design.stiffness:.5g} {u.stiffness}, B = {design.damping:.4g} "
             f"{u.damping}; worst margin {design.gain_margin_db:.4f} dB")
    return plot_robust_slice(xs, ys, margin, wxy, min_gain_margin_db, (x, y), fmt, title, u)


def hardware_plot_job(device: Device, target: HardwareTarget, free: str, points: int, fmt: str,
                      value_range: tuple[float, float] | None = None) -> bytes:
    """The hardware design and its trade-off figure, both in the worker (under the request time budget)."""
    design = design_hardware(device, target, free, points=points, value_range=value_range)
    return plot_hardware(design, target, fmt, device_title(device, free=f"device.{free}"), units(device))


def simulation_plot_job(device: Device, scene: Scene, fmt: str) -> bytes:
    """The scene simulated and drawn in the worker: the per-sample trajectory never reaches the server."""
    result, _ = simulate_job(device, scene)
    return plot_simulation(result, fmt, device=device, scene=scene)


def identify_plot_job(data, model: str, known, friction: bool, confidence: float, max_delay, fmt: str) -> bytes:
    """The identification and its measured-vs-fitted figure, both in the worker (under the request budget)."""
    from optim.identification import identify

    from .plots_identification import plot_identification

    return plot_identification(identify(data, model, known, friction, confidence, max_delay), fmt,
                               sample_time=data.sample_time)
