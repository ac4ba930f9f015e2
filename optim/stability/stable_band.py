"""The stable set in K past B_max (issue 34): K_cr = 0 need not mean that no K > 0 is stable.

At B ≥ B_max the damper-only loop (K = 0⁺) already has poles outside the unit circle, so K_cr = 0 (the contract's
"smallest K with a pole on the circle" is 0⁺).  Raising K moves those poles, and a cable's pair can come back in
and leave again later: the stable set in K is then a band [K_lo, K_hi] that does not start at 0 (an audit found one
in 7 of 99 cables 0.05 % above B_max: K from ≈ 3e4 to 1.6e6 N/m, where zwidth said "no positive stiffness is
stable" and /v1/simulate said stable).

The count of closed-loop poles outside the circle changes only where a pole is on it, i.e. at a phase crossover
(H(θ) = K real and positive, θ ∈ (0, π]); between two consecutive crossovers it is constant.  So:

* the crossovers come from the scan (optim.stability.crossovers, every one refined to 4 ulp in ω): they are the
  band's edges, exactly;
* the scan's own prediction of each interval's count: the count crossing a crossover changes by ±2 (a conjugate
  pair, θ ∈ (0, π)) or ±1 (Nyquist), outwards where Im dH/dθ > 0 (a pole at e^{jθ} moves by dz = j·z·dK/H'(θ));
* the closed loop decides: every interval's count (or each interval the prediction calls stable or nearly so,
  when there are many) is taken from the closed-loop eigenvalues or the argument principle
  (optim.verification's points, optim.stability.closed_loop: its own discretisation, sharing no code with the
  scan), and each band edge is held to it just inside and just outside (relative 1e-6, else 1e-3).

Anything the closed loop cannot decide, or a contradiction between it and the scan, makes the answer
``undetermined`` (with the reason), never a band or "none" by guess.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from models.device import Device
from models.velocity_filter import Rendering, filter_spec

__all__ = ["StableBand", "stable_band", "crossings_at", "EDGE_STEPS", "ALL_INTERVALS_MAX"]

#: relative steps at which each band edge is held to the closed loop (the second when the first is not decided)
EDGE_STEPS = (1e-6, 1e-3)
#: up to this many intervals between crossovers every one is counted by the closed loop; beyond it, those the
#: scan's prediction gives at most 2 unstable poles (a missed or misdirected crossing could empty them)
ALL_INTERVALS_MAX = 40


@dataclass(frozen=True)
class StableBand:
    """The stable set in K at a B where K_cr = 0."""

    status: Literal["none", "band", "undetermined"]
    """none: the closed loop is unstable between every pair of crossovers (no K > 0 is stable); band: it is stable
    on ``band``; undetermined: the closed loop could not decide (``reason``)."""
    band: tuple[float, float] | None
    """[K_lo, K_hi] [N/m] (K_hi may be inf), the lowest stable band; None unless status is band."""
    others: int
    """further disjoint stable bands above ``band``."""
    checked: int
    """closed-loop decisions made (intervals and edges)."""
    reason: str


def crossings_at(device: Device, beta: float) -> list[tuple[float, float, int]]:
    """(α, θ, change of the unstable count) of every K > 0 crossover at β, by the scan, sorted by α."""
    from optim.stability.crossovers import positive_real_crossings, scan_grid, theta_min
    from optim.stability.margins import loop_plant
    from optim.stability.undamped_cable import is_undamped_cable, true_crossings

    plant = loop_plant(device)
    hints = tuple(plant.pole_angles()) + tuple(plant.zero_angles())
    grid = scan_grid(theta_min(device.delta + beta, device.delay_samples), device.delay_samples, hints,
                     width_hint=max(device.delta, 1e-6))     # the scan's own grid (optim.stability.margins)

    def h(theta: np.ndarray) -> np.ndarray:
        return -plant.inverse_response(theta) + beta * np.expm1(-1j * theta)

    found = positive_real_crossings(h, grid)
    if is_undamped_cable(device):
        # a lossless cable: the scan's roots of Im H at poles of H (a zero of G on the circle, a locus's K → ∞ end)
        # are no crossings (optim.stability.undamped_cable)
        found = true_crossings(h, found)
    out = []
    for c in found:
        th = c.angle
        step = 1e-7 * min(th, math.pi - th) if th < math.pi else 1e-7 * math.pi
        if th < math.pi:
            lo, hi = h(np.array([th - step, th + step]))
            slope = (hi - lo) / (2.0 * step)
            out.append((c.value, th, 2 if slope.imag > 0 else -2))
        else:
            lo = h(np.array([math.pi - step]))[0]
            # H(π) real; Im H just below π has the sign of −Im H'(π)·step: outward where Im H' > 0
            out.append((c.value, th, 1 if lo.imag < 0 else -1))
    return sorted(out)


def _refined_edge(device: Device, damping: float, beta: float, alpha: float, cross: list) -> float | None | bool:
    """The crossover at α re-solved in 40 digits where its cancellation ratio exceeds RHO_REFINE (None: not needed;
    False: the re-solve did not settle or gave K ≤ 0)."""
    from optim.stability.margins import loop_plant
    from optim.stability.near_b_max import RHO_REFINE, cancellation_ratio, refine_cable_crossover
    from optim.stability.reference import REFERENCE_STIFFNESS_MAX_DELAY_SAMPLES

    if not math.isfinite(alpha):
        return None
    theta = min((c for c in cross if c[0] == alpha), key=lambda c: c[1])[1]
    if theta >= math.pi or cancellation_ratio(loop_plant(device), beta, theta, alpha) <= RHO_REFINE:
        return None
    if device.delay_samples > REFERENCE_STIFFNESS_MAX_DELAY_SAMPLES:
        return False
    got = refine_cable_crossover(device, damping, theta)
    if got is None or not got[1] > 0.0:
        return False
    return got[1]


def stable_band(device: Device, damping: float, rendering: Rendering | None = None) -> StableBand:
    """The stable set in K of the wall with virtual damping ``damping`` [N·s/m] at or above B_max (module docstring).

    ``rendering``: the wall's velocity filter and virtual mass (models.velocity_filter): the crossovers are then those
    of the rendered wall's h_K (optim.stability.rendered.band_crossings) and the closed loop carries the filter's
    states and the virtual mass (optim.verification's rendered point); None or the default: today's wall."""
    from optim.stability.closed_loop import sampled_plant
    from optim.verification import check_point

    m, t = device.mass, device.sample_time
    to_alpha, beta = t * t / m, damping * t / m
    scale = 1.0 / to_alpha
    render = None
    if rendering is not None and not rendering.is_default:
        from optim.stability.rendered import band_crossings

        render = (filter_spec(rendering, t), rendering.mass)
        cross = band_crossings(device, rendering, beta)
    else:
        cross = crossings_at(device, beta)
    # merge crossovers at the same K (to 1e-12): their changes add (an unresolved one, 0, leaves the sum unknown: 0)
    edges: list[list] = []
    for a, _, ch in cross:
        if edges and a <= edges[-1][0] * (1.0 + 1e-12):
            edges[-1][1] = 0 if 0 in (ch, edges[-1][1]) else edges[-1][1] + ch
        else:
            edges.append([a, ch])
    plant = sampled_plant(device)
    checked = 0

    def decide(alpha: float) -> bool | None:
        nonlocal checked
        checked += 1
        return check_point(device, plant, alpha, beta, render).stable

    ks = [e[0] for e in edges]
    # test points: inside each interval (0, k1), (k1, k2), …, (kn, ∞)
    tests = ([0.5 * ks[0]] if ks else [1e-9 * to_alpha]) + [math.sqrt(a * b) for a, b in zip(ks, ks[1:])] + \
        ([2.0 * ks[-1]] if ks else [])
    # the scan's prediction, from the closed loop's count at the first interval (unstable there: B ≥ B_max)
    first = decide(tests[0])
    if first is None:
        return StableBand("undetermined", None, 0, checked, "the closed loop cannot decide the loop at a small K "
                          "(a pole within rounding of the unit circle)")
    # a crossing whose direction is not resolved (a rendered wall's tangency: change 0) leaves the prediction unknown
    # from there on: those intervals are all counted by the closed loop
    predicted: list[int | None] = [0 if first else 2]
    for _, ch in edges:
        last = predicted[-1]
        predicted.append(None if last is None or ch == 0 else max(last + ch, 0))
    verdicts: list[bool | None] = [first]
    for i, alpha in enumerate(tests[1:], start=1):
        guess = predicted[i]
        if len(tests) <= ALL_INTERVALS_MAX or guess is None or guess <= 2:
            verdicts.append(decide(alpha))
        else:
            verdicts.append(False)          # guess > 2: a pair or more outside, by the directions
    if any(v is None for v in verdicts):
        j = verdicts.index(None)
        lo = 0.0 if j == 0 else ks[j - 1] * scale
        hi = ks[j] * scale if j < len(ks) else math.inf
        return StableBand("undetermined", None, 0, checked, f"the closed loop cannot decide K between {lo:.6g} and "
                          f"{hi:.6g} N/m (a pole within rounding of the unit circle)")
    bands: list[tuple[int, int]] = []   # (first interval, last interval) of each run of stable intervals
    for i, v in enumerate(verdicts):
        if v:
            if bands and bands[-1][1] == i - 1:
                bands[-1] = (bands[-1][0], i)
            else:
                bands.append((i, i))
    if not bands:
        how = ("every interval between crossovers counted" if len(tests) <= ALL_INTERVALS_MAX else
               "every interval the crossing directions leave ≤ 2 unstable poles counted, the others by the directions")
        return StableBand("none", None, 0, checked, f"the closed loop is unstable at K below, between and above all "
                          f"{len(ks)} crossovers ({how}): no positive stiffness is stable")
    i0, i1 = bands[0]
    if i0 == 0:
        return StableBand("undetermined", None, 0, checked, "the closed loop is stable at a small K although B is at "
                          "or above B_max: B_max and the closed loop disagree")
    lo_a = ks[i0 - 1]
    hi_a = ks[i1] if i1 < len(ks) else math.inf
    # an edge at a K that is a small difference of O(β) terms (just past B_max the lower one is): re-solved in 40
    # digits for a cable, as K_cr is below B_max (optim.stability.near_b_max; the double edge was 2e-6 off at 5e-9
    # past B_max in the property run)
    refined = {}
    if device.cable is not None and render is None:
        for edge in (lo_a, hi_a):
            got = _refined_edge(device, damping, beta, edge, cross)
            if got is False:
                return StableBand("undetermined", None, 0, checked, f"the band edge at K = {edge * scale:.9g} N/m is "
                                  "a difference of much larger terms and its 40-digit re-solve did not settle")
            if got is not None:
                refined[edge] = got
    steps = []
    # each edge, just inside and just outside, by the closed loop
    for edge, inside_sign in ((lo_a, 1.0), (hi_a, -1.0)):
        if not math.isfinite(edge):
            continue
        j = ks.index(edge)
        gap_lo = edge - ks[j - 1] if j > 0 else edge
        gap_hi = ks[j + 1] - edge if j + 1 < len(ks) else math.inf
        edge = refined.get(edge, edge)
        ok = None
        for step in EDGE_STEPS:
            e = min(step, 0.5 * gap_lo / edge, 0.5 * gap_hi / edge)
            inside = decide(edge * (1.0 + inside_sign * e))
            outside = decide(edge * (1.0 - inside_sign * e))
            if inside is False or outside is True:
                return StableBand("undetermined", None, 0, checked, f"the closed loop does not confirm the band edge "
                                  f"at K = {edge * scale:.9g} N/m (stable {inside} just inside, {outside} just "
                                  "outside)")
            if inside and outside is False:
                ok = True
                steps.append(e)
                break
        if not ok:
            return StableBand("undetermined", None, 0, checked, f"the closed loop cannot decide either side of the "
                              f"band edge at K = {edge * scale:.9g} N/m (a pole within rounding of the circle)")
    band = (refined.get(lo_a, lo_a) * scale, refined.get(hi_a, hi_a) * scale)
    return StableBand("band", band, len(bands) - 1, checked, (
        f"the closed loop is stable for {band[0]:.6g} < K < {band[1]:.6g} N/m (and at no smaller K): a band past "
        "B_max, its edges the crossovers there" + (" (re-solved in 40 digits)" if refined else "") +
        ", confirmed by the closed-loop eigenvalues or argument principle just inside and outside each (at "
        f"{max(steps):.0e} relative)"
        + (f"; {len(bands) - 1} further stable band(s) above it" if len(bands) > 1 else "")))
