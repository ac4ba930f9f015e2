"""The exact verdict of a linear wall scene too large for dense eigenvalues, from K_cr(B).

models/simulation/scene_poles.py decides a linear scene from its closed-loop poles up to 600 states.  A longer
delay line (up to the device's 10 000 samples) is still decided exactly when the scene's loop is the
one optim.stability.margins analyses: the wall K + B(1 - z⁻¹)/T on the rigid or cable device with its delay, no
human, force sensor or feedforward; a rendered wall K + B·V(z) + M·A(z) (a velocity filter, a virtual mass) by
optim.stability.rendered.  Then the loop is stable iff 0 < K < K_cr(B) (with B < B_max;
optim/stability/margins.py says why), a different method from the poles: the crossover scan.  K within
MARGIN_AMBIGUITY of K_cr is a pole on the circle: undetermined.

Past B_max (K_cr = 0) a band of larger K can still be stable (optim.stability.stable_band, issue 34): there the
closed loop at the scene's K decides (eigenvalues with their rounding bound, else the argument principle), and it
must agree with the band the analysis reports; a disagreement or a K on a band edge is undetermined.
"""

from __future__ import annotations

import math
from typing import Literal

from models.device import Device
from models.simulation.scene import Scene
from models.simulation.simulate import SimulationResult
from models.simulation.verdict import decide_exact
from models.velocity_filter import Rendering, filter_spec, rendering
from optim.errors import InputError
from optim.stability.closed_loop import sampled_plant
from optim.stability.margins import critical_stiffness
from optim.stability.rendered import rendered_critical_stiffness
from optim.stability.stable_band import stable_band
from optim.verification import check_point

__all__ = ["MARGIN_AMBIGUITY", "with_margin_verdict", "margin_verdict"]

#: K_cr is exact to ~1e-12 relative (optim/stability/margins.py); closer than this to it, no side is claimed.
MARGIN_AMBIGUITY = 1e-9


def margin_verdict(device: Device, scene: Scene) -> tuple[Literal["stable", "unstable", "undetermined"], str] | None:
    """(stable | unstable | undetermined, reason) from K_cr(B), or None when the scene's loop is not the
    one optim.stability.margins analyses."""
    eff = scene.effects
    if scene.controller is None or eff.human or eff.force_sensor_filter or eff.force_feedforward:
        return None
    if eff.quantization or eff.saturation or eff.coulomb_friction or scene.controller.stiffness <= 0.0:
        return None
    dev = device if eff.cable_mode is not None and device.cable is not None else device.rigid()
    dev = dev.model_copy(update={"delay": device.delay if eff.delay is not None else 0.0})
    c = scene.controller
    k, b = c.stiffness, c.damping
    wall = None
    if {"mass", "velocity_filter"} & c.model_fields_set:
        wall = rendering(c.velocity_filter, c.mass, device.sample_time)
        if wall.is_default:
            wall = None
    if wall is not None:
        # the rendered wall C = K + B·V + M·A: its own K_cr (optim.stability.rendered), never today's wall's
        try:
            crit = rendered_critical_stiffness(dev, b, wall)
        except InputError:
            return None
        source = "optim.stability.rendered, the rendered wall's crossover scan"
    else:
        crit = critical_stiffness(dev, b)
        source = "optim.stability.margins, the crossover scan"
    k_cr = crit.critical_stiffness
    if k_cr == 0.0 and dev.damping + b > 0.0 and (wall is not None or b > 0.0):   # B ≥ B_max
        return _past_b_max(dev, k, b, wall)
    where = f"K = {k:.9g} N/m against K_cr(B = {b:.6g}) = {k_cr:.9g} N/m ({source})"
    if abs(k - k_cr) <= MARGIN_AMBIGUITY * k_cr:
        return "undetermined", f"{where}: a pole on the unit circle within K_cr's accuracy"
    if k < k_cr:
        return "stable", f"every closed-loop pole lies inside the unit circle: {where}"
    why = f"; {crit.reason}" if crit.reason else ""
    return "unstable", f"a closed-loop pole lies outside the unit circle: {where}{why}"


def _past_b_max(device: Device, k: float, b: float,
                wall: Rendering | None = None) -> tuple[Literal["stable", "unstable", "undetermined"], str]:
    """K_cr = 0 (B ≥ B_max), yet a band of K may be stable (optim.stability.stable_band): the closed loop at this K
    decides (eigenvalues with their rounding bound, else the argument principle), and must agree with the band.
    ``wall``: a rendered wall's filter and virtual mass (the closed loop then carries their states)."""
    band = stable_band(device, b, wall)
    m, t = device.mass, device.sample_time
    render = (filter_spec(wall, t), wall.mass) if wall is not None else None
    point = check_point(device, sampled_plant(device), k * t * t / m, b * t / m, render)
    where = f"K = {k:.9g} N/m at B = {b:.6g} N·s/m past B_max (K_cr = 0), by the closed loop ({point.method})"
    if point.stable is None:
        return "undetermined", f"{where}: {point.reason}"
    inside = band.band is not None and band.band[0] < k < band.band[1]
    if band.status == "undetermined" or (band.band is not None and any(
            abs(k / e - 1.0) <= MARGIN_AMBIGUITY for e in band.band if math.isfinite(e))):
        return "undetermined", f"{where}: {'stable' if point.stable else 'unstable'} there, but {band.reason}"
    if point.stable != inside:
        return "undetermined", (f"{where}: {'stable' if point.stable else 'unstable'} there, against the stable "
                                f"band's analysis ({band.reason})")
    if point.stable:
        return "stable", f"every closed-loop pole lies inside the unit circle: {where}; {band.reason}"
    return "unstable", f"a closed-loop pole lies outside the unit circle: {where}; {band.reason}"


def with_margin_verdict(device: Device, scene: Scene, result: SimulationResult) -> SimulationResult:
    """The result, decided by K_cr(B) when it is linear, has no poles (too many states) and optim.stability.margins
    analyses its loop; unchanged otherwise."""
    j = result.judgement
    if j.poles is not None or result.method != "exact-linear-recursion":
        return result
    found = margin_verdict(device, scene)
    if found is None:
        return result
    judgement = decide_exact(j.measured, found[0], found[1], "critical stiffness", j.poles_note)
    return SimulationResult(**{**result.__dict__, "verdict": judgement.verdict, "judgement": judgement})
