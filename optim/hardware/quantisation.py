"""The encoder and the friction a wall needs: ``encoder_resolution`` and ``coulomb_friction`` as free parameters of
the hardware design (issue 31: "what encoder do I need for 20 kN/m?").

The criterion is passivity of the target wall K_t as a virtual spring (B = 0: a virtual damper only lowers the
passive limit, chapter eq. 10 and zwidth's delayed Colgate–Schenkel condition), by the passive limit of
optim.stability.nonlinear:

    K_t ≤ min(S, 2f_c/q),   S = 2b/T (Abbott & Okamura 2005) or, with delay or a cable, zwidth's delayed limit
                            (covered = false there: an extension, not the theorem).

S does not depend on q or f_c, so the loosest hardware is in closed form:

    encoder_resolution (coarser is cheaper, direction max):  q* = 2f_c/K_t  (needs f_c > 0)
    coulomb_friction (less is more transparent, direction min): f_c* = K_t·q/2  (needs q)

and the target is out of reach for every q (every f_c) when S < K_t.  The answer is then checked exactly: the
nonlinear analysis of the device with q* (f_c*) at K_t must find the wall passive with its passive limit equal to
K_t within 1e-12, and the analysis one step (1 %) looser must find it not passive.  With ``device.travel`` the
encoder answer carries the counts it implies over the travel, travel/q*.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Literal

from models.device import Device
from optim.errors import InputError
from optim.hardware.hardware_targets import HardwareTarget
from optim.stability.nonlinear import NonlinearAnalysis, analyse_nonlinear, passive_stiffness_limit

__all__ = ["QUANTISATION_FREE", "QuantisationCheck", "QuantisationDesign", "design_quantisation",
           "check_quantisation_request"]

#: free parameter → (direction that loosens the hardware, unit)
QUANTISATION_FREE: dict[str, tuple[str, str]] = {"encoder_resolution": ("max", "m"), "coulomb_friction": ("min", "N")}
_LOOSER = 0.01
#: [m] the largest encoder resolution a device takes (models.device: encoder_resolution ≤ 1000)
_Q_MAX = 1000.0
_RTOL = 1e-12


@dataclass(frozen=True)
class QuantisationCheck:
    """The nonlinear analysis (optim.stability.nonlinear) of the target wall on the device with the answer."""

    value: float
    """the free parameter checked [SI]."""
    passive_stiffness_limit: float
    """[N/m] the passive limit there."""
    regime: str | None
    limit_cycle_exists: bool
    limit_cycle_amplitude: float | None
    """[m]"""


@dataclass(frozen=True)
class QuantisationDesign:
    status: Literal["optimal", "infeasible"]
    free: str
    direction: str
    target_stiffness: float
    """K_t [N/m] (a virtual spring, B = 0)."""
    value: float | None
    """q* [m per count] or f_c* [N]; None when infeasible."""
    counts_over_travel: float | None
    """travel/q* when the free parameter is the encoder and device.travel is given."""
    sampling_term: float
    """[N/m] S of the module docstring (the part of the limit no encoder or friction changes)."""
    covered: bool
    """Abbott & Okamura's theorem covers the device (no delay, rigid)."""
    source: str
    reason: str
    at_value: QuantisationCheck | None
    """the analysis at the answer: passive, limit = K_t."""
    looser: QuantisationCheck | None
    """the analysis 1 % looser: not passive."""
    confirmed: bool
    """at_value passive with its limit K_t (1e-12) and looser not passive."""
    elapsed_ms: float


def check_quantisation_request(target: HardwareTarget, has_range: bool) -> None:
    """InputError naming the field for what the encoder/friction design does not take: it needs target.stiffness
    and answers in closed form (no feedforward target, no scanned range)."""
    if target.stiffness is None:
        raise InputError("target.stiffness", "the encoder or friction a wall needs is asked for a target stiffness")
    for name in ("force_gain", "apparent_mass", "max_damping"):
        if getattr(target, name) is not None:
            raise InputError(f"target.{name}", "not used with free = encoder_resolution | coulomb_friction (the "
                                               "virtual spring's passivity: B = 0, no feedforward)")
    if has_range:
        raise InputError("range", "not used with free = encoder_resolution | coulomb_friction: the answer is in "
                                  "closed form")


def _check(device: Device, free: str, value: float, stiffness: float) -> tuple[QuantisationCheck, NonlinearAnalysis]:
    dev = device.model_copy(update={free: value})
    nl = analyse_nonlinear(dev, stiffness, 0.0)
    assert nl is not None
    c = nl.limit_cycle
    return QuantisationCheck(value, nl.passive.stiffness, nl.regime, c.exists, c.amplitude), nl


def design_quantisation(device: Device, stiffness: float, free: str) -> QuantisationDesign:
    """The loosest encoder resolution or Coulomb friction that keeps the virtual spring ``stiffness`` passive
    (module docstring).  InputError naming ``free`` or ``target.stiffness`` for a question with no answer."""
    t0 = time.perf_counter()
    if free not in QUANTISATION_FREE:
        raise InputError("free", f"must be one of {', '.join(QUANTISATION_FREE)}")
    if not (math.isfinite(stiffness) and stiffness > 0):
        raise InputError("target.stiffness", "must be a finite K > 0 [N/m]")
    direction = QUANTISATION_FREE[free][0]
    q, f_c = device.encoder_resolution, device.coulomb_friction or 0.0
    if free == "coulomb_friction" and q is None:
        raise InputError("device.encoder_resolution", "the friction a wall needs is K_t·q/2: give the encoder's q")
    probe = device.model_copy(update={"encoder_resolution": q if q is not None else 1.0,
                                      "coulomb_friction": f_c if f_c > 0 else None})
    limit = passive_stiffness_limit(probe, 0.0)
    sampling = limit.sampling_term

    def done(status, value, reason, at=None, looser=None, confirmed=False) -> QuantisationDesign:
        counts = None
        if free == "encoder_resolution" and value is not None and device.travel is not None:
            counts = device.travel / value
        return QuantisationDesign(status, free, direction, stiffness, value, counts, sampling, limit.covered,
                                  limit.source, reason, at, looser, confirmed, (time.perf_counter() - t0) * 1e3)

    if sampling < stiffness:
        term = "2b/T" if limit.covered else "zwidth's delayed passive limit"
        return done("infeasible", None, f"the sampling term {sampling:.6g} N/m ({term}) is below K_t = "
                    f"{stiffness:.6g} N/m: no encoder and no friction make this virtual spring passive (more physical "
                    "damping, a shorter sample time or less delay do)")
    if free == "encoder_resolution":
        if f_c <= 0:
            return done("infeasible", None, "without Coulomb friction no quantised wall is passive (2f_c/q = 0: "
                        "Abbott & Okamura's chatter at the count scale): give device.coulomb_friction")
        value = 2 * f_c / stiffness
        if 2 * f_c / value < stiffness:          # the rounding of the quotient: the edge kept on the passive side
            value = math.nextafter(value, 0.0)
        cap = device.travel if device.travel is not None else _Q_MAX
        if value > cap:
            value = cap
            what = f"the travel {cap:g} m" if device.travel is not None else f"the largest resolution taken, {cap:g} m"
            reason = (f"2f_c/K_t = {2 * f_c / stiffness:.6g} m is coarser than {what}: any encoder up to it keeps "
                      "K_t passive")
        else:
            reason = f"q ≤ 2f_c/K_t = {value:.6g} m per count keeps K_t = {stiffness:.6g} N/m passive"
        looser_value = value * (1 + _LOOSER)
    else:
        assert q is not None
        value = stiffness * q / 2
        if 2 * value / q < stiffness:
            value = math.nextafter(value, math.inf)
        reason = f"f_c ≥ K_t·q/2 = {value:.6g} N keeps K_t = {stiffness:.6g} N/m passive"
        looser_value = value * (1 - _LOOSER)
    at, _ = _check(device, free, value, stiffness)
    capped = free == "encoder_resolution" and value < 2 * f_c / stiffness * (1 - 1e-15)
    confirmed = at.regime == "passive" and (capped or abs(at.passive_stiffness_limit - stiffness) <= _RTOL * stiffness)
    looser = None
    if not capped:
        looser, _ = _check(device, free, looser_value, stiffness)
        confirmed = confirmed and looser.regime != "passive"
    reason += f" ({limit.source})"
    if not confirmed:
        reason += "; the nonlinear analysis at the answer did not confirm it (see at_value, looser)"
    return done("optimal", value, reason, at, looser, confirmed)
