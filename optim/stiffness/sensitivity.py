"""Sensitivities of the optimal stiffness to the device (physical damping, delay, sample time, mass).

At a regular optimum the envelope theorem gives d(objective*)/dp = ∂L/∂p, which
Ipopt returns as lam_p with CasADi's sign convention (checked against
finite differences of re-solved designs in tests): dα*/dp = α_ref·lam_p.
The NLP's parameters p (the ZOH matrices E, Γ0, Γ1, δ, the limits in
dimensionless form) depend on the device smoothly; ∂p/∂q comes from
differencing that map (matrix exponentials, no optimisation involved), and
K* = α*·m/T² adds its own scale's derivative.

A cable device's damping and mass are scaled proportionally (b_r : b_d and
m_r : m_d kept); the cable link itself is unchanged.
"""

from __future__ import annotations

import math

import numpy as np

from models.device import Device
from models.discretize import split_delay
from optim.errors import InputError
from optim.stiffness.loop import loop_matrices

__all__ = ["perturbed_device", "sensitivities", "PARAMETERS"]

# parameter, designer's step, label of the step, verb
PARAMETERS = (("damping", 1.0, "+1 N·s/m of physical damping"),
              ("delay", 1e-3, "+1 ms of loop delay"),
              ("sample_time", 1e-4, "+0.1 ms of sample time"),
              ("mass", 1.0, "+1 kg of moving mass"))


def perturbed_device(device: Device, parameter: str, value: float) -> Device:
    """The device with one parameter set to ``value`` (cable: proportional split)."""
    data = device.model_dump()
    data["preset"] = None
    cable = data.get("cable")
    if parameter in ("delay", "sample_time"):
        data[parameter] = value
    elif parameter == "damping":
        data["damping"] = value
        if cable is not None:
            b = cable["motor_damping"] + cable["body_damping"]
            if b > 0:
                cable["motor_damping"] *= value / b
                cable["body_damping"] = value - cable["motor_damping"]
            else:
                share = cable["motor_mass"] / (cable["motor_mass"] + cable["body_mass"])
                cable["motor_damping"], cable["body_damping"] = value * share, value * (1 - share)
    elif parameter == "mass":
        data["mass"] = value
        if cable is not None:
            m = cable["motor_mass"] + cable["body_mass"]
            cable["motor_mass"] *= value / m
            cable["body_mass"] = value - cable["motor_mass"]
    else:
        raise InputError("parameter", f"unknown device parameter {parameter!r}")
    return Device.model_validate(data)


def _device_params(ctx, device: Device, like: np.ndarray, at) -> np.ndarray:
    """The NLP parameter vector for another device, same structure and scalings."""
    from optim.stiffness.design import problem_params

    ks, bs = device.stiffness_scale, device.damping_scale
    k_cap = min(ctx.req.stiffness_caps().values(), default=math.inf)
    b_cap = min(ctx.req.damping_caps(device.sample_time).values(), default=math.inf)
    p = problem_params(ctx, loop_matrices(device).flat(), device.delta, k_cap / ks if math.isfinite(k_cap) else 1e30,
                       b_cap / bs if math.isfinite(b_cap) else 1e30, at.alpha_ref, at.beta_ref, [])
    p[len(p) - 2 * at.key.cuts:] = like[len(like) - 2 * at.key.cuts:]     # passivity cut angles: integers of delay
    return p


def _step_size(device: Device, parameter: str) -> float:
    """The size of a one-sided difference step (error ~1e-7 relative; the map device → ZOH matrices is smooth)."""
    value = getattr(device, parameter)
    return 1e-7 * max(abs(value), {"damping": 1e-2 * device.damping_scale, "delay": device.sample_time,
                                   "sample_time": device.sample_time, "mass": device.mass}[parameter])


def _perturbed(device: Device, parameter: str) -> tuple[float, Device] | str:
    """(signed step, perturbed device) inside the input domain with the same whole samples of delay, or why not.

    One-sided steps halve the matrix exponentials a central difference would need.  Forward first; backward at
    an edge of the input domain (T = 1 s, a 10,000-sample delay, a 1e12 bound).  The NLP is built on the whole
    samples of delay d, so a step must keep d: on a whole sample the delay may only grow (T only shrink).
    """
    h = _step_size(device, parameter)
    value = getattr(device, parameter)
    whole, frac = split_delay(device.delay_samples)
    signs: tuple[float, ...] = (1.0, -1.0)
    why = []
    if device.delay > 0 and frac == 0.0 and parameter in ("delay", "sample_time"):
        signs = (1.0,) if parameter == "delay" else (-1.0,)
        why.append(f"on a whole sample of delay only a {'longer delay' if parameter == 'delay' else 'shorter T'} "
                   "keeps the whole samples the design is built on")
    for sign in signs:
        try:
            dev = perturbed_device(device, parameter, value + sign * h)
        except ValueError as exc:          # pydantic's ValidationError too: the step left the input domain
            errors = getattr(exc, "errors", None)
            msg = errors()[0]["msg"].removeprefix("Value error, ") if callable(errors) else str(exc)
            why.append(f"a step of {sign * h:+.3g} leaves the input domain: {msg}")
            continue
        if split_delay(dev.delay_samples)[0] != whole:
            why.append("the step changes the whole samples of delay the design is built on")
            continue
        return sign * h, dev
    return "; ".join(dict.fromkeys(why))


def sensitivities(ctx, at) -> tuple[tuple, str | None]:
    from optim.stiffness.design import Sensitivity

    lo, hi = at.interval
    b = at.sol.b * at.beta_ref
    if lo > 0 and abs(b - lo) <= 1e-7 * max(hi - lo, 1e-300) or abs(b - hi) <= 1e-7 * max(hi - lo, 1e-300) \
            and hi < ctx.beta_hi * (1 - 1e-6):
        return (), ("the optimum sits where a phase crossover appears or vanishes (a fold of the boundary): "
                    "K* is not differentiable there")
    device = ctx.device
    alpha = at.sol.a * at.alpha_ref
    out = []
    note = None
    skip: tuple[str, ...] = ()
    if ctx.req.passivity and at.passive_k is not None and at.stiffness >= at.passive_k * (1 - 1e-6):
        _, f = split_delay(device.delay_samples)
        if f == 0.0:
            skip = ("delay", "sample_time")
            note = ("passivity is active and counts whole samples of delay (a fraction rounds up): at this "
                    "whole-sample delay K* jumps with the delay, so no delay or sample-time sensitivity is given")
    edge = []
    for name, step, label in PARAMETERS:
        if name in skip:
            continue
        moved = _perturbed(device, name)
        if isinstance(moved, str):
            edge.append(f"no {name} sensitivity: no one-sided step stays in the input domain ({moved})")
            continue
        h, dev = moved
        dp = (_device_params(ctx, dev, at.params, at) - at.params) / h
        dalpha = at.alpha_ref * float(at.sol.lam_p @ dp)
        scale = device.stiffness_scale
        dscale = {"mass": scale / device.mass, "sample_time": -2 * scale / device.sample_time}.get(name, 0.0)
        dk = scale * dalpha + alpha * dscale
        change = dk * step
        verb = "buys" if change >= 0 else "costs"
        out.append(Sensitivity(name, dk, step, label, change,
                               f"{label} {verb} {abs(change):.4g} N/m of stiffness"))
    if edge:
        note = "; ".join(([note] if note else []) + edge)
    return tuple(out), note
