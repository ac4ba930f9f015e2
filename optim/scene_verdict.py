"""The exact verdict of a linear wall scene too large for dense eigenvalues, from K_cr(B).

models/simulation/scene_poles.py decides a linear scene from its closed-loop poles up to 600 states.  A longer
delay line (up to the device's 10 000 samples) is still decided exactly when the scene's loop is the
one optim.stability.margins analyses: the wall K + B(1 - z⁻¹)/T on the rigid or cable device with its delay, no
human, force sensor or feedforward.  Then the loop is stable iff 0 < K < K_cr(B) (with B < B_max;
optim/stability/margins.py says why), a different method from the poles: the crossover scan.  K within
MARGIN_AMBIGUITY of K_cr is a pole on the circle: undetermined.
"""

from __future__ import annotations

from typing import Literal

from models.device import Device
from models.simulation.scene import Scene
from models.simulation.simulate import SimulationResult
from models.simulation.verdict import decide_exact
from optim.stability.margins import critical_stiffness

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
    k, b = scene.controller.stiffness, scene.controller.damping
    crit = critical_stiffness(dev, b)
    k_cr = crit.critical_stiffness
    where = f"K = {k:.9g} N/m against K_cr(B = {b:.6g}) = {k_cr:.9g} N/m (optim.stability.margins, the crossover scan)"
    if abs(k - k_cr) <= MARGIN_AMBIGUITY * k_cr:
        return "undetermined", f"{where}: a pole on the unit circle within K_cr's accuracy"
    if k < k_cr:
        return "stable", f"every closed-loop pole lies inside the unit circle: {where}"
    why = f"; {crit.reason}" if crit.reason else ""
    return "unstable", f"a closed-loop pole lies outside the unit circle: {where}{why}"


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
