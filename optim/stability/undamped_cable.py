"""K_cr(B) and B_max of a cable with every damping 0 (b_r = b_d = b_c = 0), issue 17.

Such a plant is lossless: G(s) = 1/(M s²) + c/(s² + ω_n²) (c > 0, collocated).  Its sampled poles lie exactly on
the unit circle (z = 1 twice and e^{±jθ_n}), and with a whole-sample delay so do its zeros: the ZOH of both terms
carries the factor (z + 1), and what remains is a palindromic quadratic with a negative discriminant, whose roots
e^{±jθ_z} lie on the circle.  The crossover scan (optim.stability.crossovers) then meets three things that are not
crossovers, each once per device, and took them for answers (docs/properties_analysis.md, four devices):

* the damper-only loop h_d = −1/(G_n·(1 − e^{−jθ})) is 0 at θ_n: the cable pair at β = 0, where its root locus
  starts, not a pole reaching the circle at some β > 0 (a rounding-sized "B_max");
* Im H (or Im h_d) changing sign through ±∞ at a zero of G on the circle: the end of a locus as K → ∞, where H
  has a pole; the scan's solver converges onto the pole and reads Re H ≈ 1e16 off the rounding;
* H(π) = ∞ when G(−1) = 0: no Nyquist crossover, though the rounded H(π) has a finite real part.

Each is recognised from H itself: a root of Im H is kept only where Im H is small against |H| (a pole is not),
and a damper root only away from θ_n.  What the scan's premise needs as well (optim.stability.margins: at K = 0⁺
the loop is stable for 0 < B < B_max) fails when B pushes the cable pair outwards: the locus leaves e^{jθ_n} along
z − p ≈ −β·r (r the residue of (1 − z⁻¹)G_n at p), outwards exactly when Im h_d′(θ_n) > 0, since h_d ≈ h_d′·(θ − θ_n)
near θ_n and p̄·(−r) = j/h_d′.  With a whole delay that is the sign of −cos((d + 1)θ_n): the damper's phase lag,
d + 1 samples, turning its damping negative at the cable mode.

So: outwards and B below the first true damper crossover β₁: K_cr = 0 (no pole can come back in before β₁);
inwards: B_max = β₁ and K_cr is the smallest true crossover.  Every other case (B ≥ β₁ after an outward departure,
a departure along the circle, a mode aliased onto z = ±1) is decided by the closed loop at a small K or refused, and
every answer the closed loop (optim.verification, eigenvalues or the argument principle) contradicts is refused:
InputError on ``device.cable`` with the reason.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from models.device import Device
from optim.errors import InputError
from optim.stability.crossovers import Crossing

__all__ = ["is_undamped_cable", "true_crossings", "departs_outwards", "refuse", "confirm_or_refuse", "stable_at_small_k",
           "POLE_RATIO", "AT_MODE_RTOL", "NEAR_LOSSLESS_GAP", "mode_gap", "confirm_near_lossless"]

#: a root of Im H with |Im H| above this fraction of |H| is a pole of H (a zero of G on the circle), not a crossing
POLE_RATIO = 1e-3
#: a damper-loop root within this relative distance of θ_n is the β = 0 start of the cable pair's locus
AT_MODE_RTOL = 1e-7
#: a cable mode closer than this to the unit circle (1 − |p|, p its sampled pole; ≈ ζ·ω_n·T) but not on it: the
#: crossover scan's answer is held to the closed loop, as for the lossless cable.  Random cables with dampings down to
#: 1e-22 (δ and ζ·ω_n·T) gave 2 scan answers in 400 that the closed loop contradicts, both with the mode within 1e-17 of
#: the circle and B > 0 (one K_cr = 2,422 N/m where B drives the mode out and the 40-digit reference says 0); none
#: above 1e-17.  Down to 1e-12 the test suite's and benches' cables (ζ ≥ 1e-9) hold the scan to the reference.
NEAR_LOSSLESS_GAP = 1e-12
#: the central difference of h_d at θ_n(1 ± s), and how far Im h_d′ must be from 0 relative to |h_d′|
_STEP = 1e-6
_TANGENT = 1e-6


def is_undamped_cable(device: Device) -> bool:
    """Every damping of the cable zero (b_r = b_d = b_c = 0): the plant is lossless."""
    cb = device.cable
    return cb is not None and cb.motor_damping == 0.0 and cb.body_damping == 0.0 and cb.damping == 0.0


def refuse(rule: str) -> InputError:
    return InputError("device.cable", "with every cable damping 0 (motor_damping, body_damping, damping) " + rule +
                      "; give the cable a small damping, or analyse it without B")


def true_crossings(h: Callable[[np.ndarray], np.ndarray], found: Sequence[Crossing],
                   mode_angles: Sequence[float] = ()) -> list[Crossing]:
    """The scan's crossings without the poles of h (K → ∞ ends of loci, and a Nyquist point where G(−1) = 0)
    and, with ``mode_angles``, without the zeros of h there (the damper loop's β = 0 start of the cable pair)."""
    if not found:
        return []
    theta = np.array([c.angle for c in found])
    v = h(theta)
    keep = np.abs(v.imag) <= POLE_RATIO * np.abs(v)
    out = []
    for c, ok in zip(found, keep):
        if ok and not any(abs(c.angle / a - 1.0) <= AT_MODE_RTOL for a in mode_angles if a > 0):
            out.append(c)
    return out


def departs_outwards(h_damper: Callable[[np.ndarray], np.ndarray], theta_n: float) -> bool | None:
    """Whether virtual damping B → 0⁺ moves the cable pair at e^{±jθ_n} out of the unit circle (module docstring);
    None when the locus leaves along the circle (Im h_d′ within 1e-6 of 0 relative to |h_d′|: a whole delay with
    cos((d + 1)θ_n) = 0, e.g. ω_n T = 0.9π and d = 4): first order cannot say.

    Raises the refusal when θ_n is within 1e-9 of 0 or π (the pair meets the poles or zeros at z = ±1)."""
    if not (1e-9 < theta_n < math.pi - 1e-9):
        raise refuse(f"the cable mode is sampled at {theta_n:.6g} rad per sample, on z = ±1: whether virtual damping "
                     "stabilises it cannot be decided")
    lo, hi = h_damper(np.array([theta_n * (1.0 - _STEP), theta_n * (1.0 + _STEP)]))
    slope = (hi - lo) / (2.0 * _STEP * theta_n)
    if not np.isfinite(slope):
        raise refuse("the damper-only loop is not finite beside the cable mode: whether virtual damping stabilises "
                     "it cannot be decided")
    if abs(slope.imag) <= _TANGENT * abs(slope):
        return None
    return bool(slope.imag > 0.0)


def confirm_or_refuse(device: Device, damping: float, critical: float, next_crossing: float | None = None) -> None:
    """The closed loop (optim.verification: eigenvalues, else the argument principle) must confirm K_cr = ``critical``
    (0: unstable at a small K; a finite K: stable just below, unstable just above; inf, which no finite set of gains
    proves: not contradicted by a large K); a contradiction is refused.  Where the closed loop cannot decide either
    (K_cr → 0 next to B_max, or B → 0: poles within rounding of the circle) the answer stands as it does for a damped
    device, and ``verify`` says not checkable."""
    from optim.verification import verify_critical_stiffness

    v = verify_critical_stiffness(device, damping, critical, next_crossing=next_crossing)
    if v.verdict == "contradicted":
        what = ("no positive stiffness is stable" if critical == 0.0 else "every positive stiffness is stable"
                if math.isinf(critical) else f"K_cr = {critical:.6g} N/m")
        raise refuse(f"the crossover scan says {what} at B = {damping:.6g} N·s/m, but the closed loop does not "
                     f"confirm it ({v.verdict}: {v.reason})")


def mode_gap(plant) -> float:
    """The least 1 − |p| over the plant's oscillatory sampled poles p = 1 + λ (λ of its modal form's E = Φ − I, never
    Φ − I by subtraction); inf without a modal form or an oscillatory pole.  Kept with the plant (its _cache)."""
    cache = getattr(plant, "_cache", None)
    if cache is not None and "mode_gap" in cache:
        return cache["mode_gap"]
    modal = plant.modal_form()
    gap = math.inf if modal is None else \
        min((-(abs(1.0 + lam) - 1.0) for lam in modal[0] if lam.imag != 0.0), default=math.inf)
    if cache is not None:
        cache["mode_gap"] = gap
    return gap


def confirm_near_lossless(device: Device, damping: float, critical: float) -> str | None:
    """A cable whose mode lies within :data:`NEAR_LOSSLESS_GAP` of the unit circle: the closed loop must not
    contradict the scan's K_cr; a contradiction is refused on ``device.cable``.  Returns None when the closed loop
    confirms the answer, else why it cannot (the answer stands, and the analysis claims no error bound for it: a probe
    cable at δ ≈ 1e-16 had K_cr 40 % off the 40-digit reference where the closed loop could not decide)."""
    from optim.verification import verify_critical_stiffness

    v = verify_critical_stiffness(device, damping, critical)
    if v.verdict == "contradicted":
        raise InputError("device.cable", f"its mode lies within {NEAR_LOSSLESS_GAP:g} of the unit circle (its dampings "
                         "are nearly 0): "
                         f"the crossover scan says K_cr = {critical:.6g} N/m at B = {damping:.6g} N·s/m, but the "
                         f"closed loop does not confirm it ({v.reason}); give the cable more damping, or use method "
                         "'reference'")
    return None if v.verdict == "confirmed" else (v.reason or "the closed loop cannot decide")


def stable_at_small_k(device: Device, damping: float) -> bool:
    """Whether the closed loop with this B is stable as K → 0⁺ (optim.verification at a small K), where the cable
    mode's departure alone cannot say; the refusal when the closed loop cannot decide either."""
    from optim.verification import verify_critical_stiffness

    v = verify_critical_stiffness(device, damping, 0.0)
    if v.verdict == "not_checkable":
        raise refuse(f"whether B = {damping:.6g} N·s/m leaves the cable mode inside the unit circle cannot be decided "
                     f"({v.reason})")
    return v.verdict == "contradicted"      # "K_cr = 0 but the loop is stable at a small K"
