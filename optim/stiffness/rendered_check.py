"""The exact check of a rendered stiffness design: what labels it (optimal only if this agrees).

At the design's (K, B, filter, M) it recomputes, with code the design's search does not use for its label:

* K_cr(B) by the exact rendered analysis (optim.stability.rendered): the margin 20·log10(K_cr/K) must meet the
  requirement;
* passivity (when required) by the general Colgate–Schenkel scan of optim.stability.passivity_rendered (the
  supremum of the bound over θ, not the design's largest-passive-K routine);
* the noise rules (when asked) from models.velocity_noise: B·q·max|s_k| ≤ max_force_noise,
  B·q·sqrt(Σh²/12) ≤ max_force_noise_rms, within 1e-9 relative.
"""

from __future__ import annotations

import math

from models.device import Device
from models.velocity_filter import LowPass, rendering
from models.velocity_noise import force_noise_rms, force_step
from optim.stability.passivity_rendered import rendered_passivity
from optim.stability.rendered import rendered_critical_stiffness
from optim.stiffness.design import StiffnessDesign
from optim.stiffness.requirements import CutoffDesign, StiffnessRequirements

__all__ = ["rendered_exact_check", "NOISE_RTOL"]

#: a noise limit counts as met within this (relative): the designed cutoff's B is clipped to the exact cap
NOISE_RTOL = 1e-9


def rendered_exact_check(device: Device, req: StiffnessRequirements, design: StiffnessDesign, velocity_filter=None):
    from optim.design_ladder import exact_check

    filt = design.rendered
    assert filt is not None and design.stiffness is not None and design.damping is not None
    spec = velocity_filter if velocity_filter is not None else req.velocity_filter
    if filt.designed or isinstance(spec, CutoffDesign):
        spec = LowPass(kind="low_pass", cutoff_hz=float(filt.cutoff_hz or 0.0), order=2 if filt.order == 2 else 1)
    rend = rendering(spec, filt.mass, device.sample_time)
    k, b = design.stiffness, design.damping
    kcr = rendered_critical_stiffness(device, b, rend).critical_stiffness
    passive = rendered_passivity(device, k, b, rend).passive if req.passivity else None
    check = exact_check(kcr, k, req.min_gain_margin_db, "rendered design", passive)
    broken = []
    q, t = req.quantization, device.sample_time
    if q is not None and req.max_force_noise is not None:
        step = force_step(b, q, rend.velocity, t)
        if not step <= req.max_force_noise * (1 + NOISE_RTOL):
            broken.append(f"its damper force step B·q·max|s_k| = {step:.6g} N exceeds max_force_noise "
                          f"{req.max_force_noise:g} N")
    if q is not None and req.max_force_noise_rms is not None:
        rms = force_noise_rms(b, q, rend.velocity, t)
        if not rms <= req.max_force_noise_rms * (1 + NOISE_RTOL):
            broken.append(f"its damper force noise {rms:.6g} N rms exceeds max_force_noise_rms "
                          f"{req.max_force_noise_rms:g} N")
    for name, cap in req.stiffness_caps().items():
        if not k <= cap:
            broken.append(f"K = {k:.6g} N/m exceeds {name}'s {cap:.6g} N/m")
    if req.max_damping is not None and not b <= req.max_damping:
        broken.append(f"B = {b:.6g} N·s/m exceeds max_damping {req.max_damping:g}")
    if broken or not math.isfinite(k):
        from dataclasses import replace

        text = check.statement.replace("safe: ", "UNSAFE: ", 1) if check.safe else check.statement
        return replace(check, meets_min_gain_margin=False, statement=text + "; " + "; ".join(broken))
    return check
