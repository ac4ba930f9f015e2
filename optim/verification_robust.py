"""``verify`` for a robust design: the design checked on the closed loop at every corner of its box, at the worst
device it found and at the worst device of an independent interior search.

A robust design claims that its controller keeps the required margin (and, when asked, passivity) for every
device of the box.  Finitely many devices can be checked: every corner of the box (over the parameters that
enter the loop; the others held at their nominal value, clipped into the box) and the worst device the
design's own search found (and, with passivity, its least passive device).  At each of them:

* the project's exact analysis gives the critical gain there (optim.stability.margins for K_cr(B),
  optim.transparency.feedforward for K_f,cr at the design's cutoff), and the margin it implies;
* that critical gain is checked independently like any answer (optim.verification: the closed loop just
  below and just above it, by eigenvalues or an argument-principle count), and so is the designed gain
  itself (stable) and, when required, passivity (recomputed from the complex form);
* the margin must be at least the required one: a device of the box below it contradicts the design.

Corners and the design's own worst device are not the box (issue 34: a cable box whose margin dipped to
5.9987 dB at an interior cable stiffness was confirmed).  So before anything is confirmed, an independent
interior search looks for a device of the box where the wall is unstable at the gain the margin promises
stable (g·K, g = 10^(GM/20)): its own sampler (a Latin hypercube drawn here, not the design's Sobol points),
its own optimizer (scipy's bounded Nelder–Mead, not the design's pattern search) and its own criterion (the
spectral radius of the closed-loop state matrix, optim.stability.closed_loop, not K_cr; for the inertia design the
force-feedforward loop's, optim.transparency.closed_loop_feedforward, not K_f,cr).  The device it ends on
is checked like the others (kind ``interior``); a device that is unstable there contradicts the design.

A rendered wall (a velocity filter, a virtual mass: ``render``) is checked the same way with its own loop: each
device's K_cr by the exact rendered analysis (optim.stability.rendered, the filter realised at that device's sample
time), every closed loop, the interior search's included, with the filter's and the virtual mass's states
(optim.stability.closed_loop_rendered).

The overall verdict is ``contradicted`` if any point contradicts, else ``not_checkable`` (with the points'
reasons) if any point cannot be decided, else ``confirmed``; every point's own verdict is listed.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.optimize import minimize

from models.device import Device
from models.filters import ButterworthLowPass
from models.velocity_filter import rendering
from optim.robust.box import STIFFNESS_PATHS, UncertaintyBox
from optim.stability.closed_loop import radius_excess, sampled_plant, stiffness_closed_loop
from optim.stability.margins import critical_stiffness
from optim.stability.rendered import rendered_critical_stiffness
from optim.transparency.feedforward import critical_force_gain, resolve_human
from optim.verification import (
    EIG_MAX_STATES,
    Verdict,
    Verification,
    labelled,
    verify_critical_force_gain,
    verify_stiffness_design,
)

__all__ = ["InteriorSearch", "PointVerification", "interior_search", "interior_search_inertia", "verify_robust_inertia",
           "verify_robust_stiffness"]

PointKind = Literal["corner", "worst", "least passive", "interior"]

#: a point's margin may fall short of the requirement by the rounding of 20·log10 of a ratio (a robust design
#: sits on its worst device: the inertia design at K_f = K_f,cr(worst)/10^(GM/20) exactly), and no more
MARGIN_TOL_DB = 1e-9
#: the interior search: Latin-hypercube points per uncertain parameter (plus a base), local searches from the
#: best few, and the evaluations each may spend
INTERIOR_SAMPLES_PER_DIM = 96
INTERIOR_BASE_SAMPLES = 64
INTERIOR_STARTS = 4
INTERIOR_MAX_EVALS_PER_DIM = 60


@dataclass(frozen=True)
class PointVerification:
    """One checked device of the box."""

    device: dict[str, float]
    """the uncertain parameters' values at this device (path → value, SI units)."""
    kind: PointKind
    """corner of the box, the worst device the design found, or (passivity) its least passive device."""
    critical_gain: float | None
    """K_cr(B) [N/m] (stiffness) or K_f,cr at the design's cutoff (inertia) of this device, exact analysis."""
    gain_margin_db: float | None
    """20·log10(critical_gain/designed gain) [dB]."""
    verdict: Verdict
    method: str | None
    reason: str | None


def _points(box: UncertaintyBox, relevant: np.ndarray, extra: list[tuple[PointKind, dict | None]]):
    """Every corner over the relevant parameters (the others at their nominal value), then the named points."""
    nominal = box.nominal_point()
    corners = np.unique(np.where(relevant, box.corners(), nominal), axis=0)
    pts: list[tuple[PointKind, np.ndarray]] = [("corner", c) for c in corners]
    for kind, values in extra:
        if values:
            x = np.array([float(values.get(p, v)) for p, v in zip(box.paths, nominal)])
            if not any(np.array_equal(x, c) for _, c in pts):
                pts.append((kind, x))
    return pts


def _overall(points: list[PointVerification], t0: float, what: str) -> Verification:
    counts = {"confirmed": 0, "contradicted": 0, "not_checkable": 0}
    for p in points:
        counts[p.verdict] += 1
    verdict: Verdict = ("contradicted" if counts["contradicted"] else
                        "not_checkable" if counts["not_checkable"] else "confirmed")
    bad = [f"{p.kind} {', '.join(f'{k} = {v:.6g}' for k, v in p.device.items())}: {p.verdict} ({p.reason})"
           for p in points if p.verdict != "confirmed"][:3]
    reason = (f"{len(points)} devices of the box ({what}): {counts['confirmed']} confirmed, "
              f"{counts['contradicted']} contradicted, {counts['not_checkable']} not checkable"
              + ("; " + "; ".join(bad) if bad else ""))
    methods = "; ".join(dict.fromkeys(p.method for p in points if p.method)) or None
    out = Verification(verdict, methods, None, None, None, None, None, None, None,
                       (time.perf_counter() - t0) * 1e3, reason, points=tuple(points))
    return labelled(out, f"the design holds on each of the {len(points)} devices of the box ({what}): its critical "
                         "gain there, the designed gain stable (and passive when required), the margin")


def _point(device: dict, kind: PointKind, critical: float | None, gained: float, required_db: float,
           v: Verification) -> PointVerification:
    """critical: None when every gain is stable there (margin +inf), 0 when none is (margin −inf)."""
    margin = math.inf if critical is None else 20.0 * math.log10(critical / gained) if critical > 0 else -math.inf
    verdict, reasons = v.verdict, [v.reason] if v.reason and v.verdict != "confirmed" else []
    if not margin >= required_db - MARGIN_TOL_DB:
        verdict = "contradicted"
        reasons.insert(0, f"the margin here is {margin:.9g} dB, below the required {required_db:g} dB")
    return PointVerification(device, kind, critical, margin, verdict, v.method, "; ".join(reasons) or None)


@dataclass(frozen=True)
class InteriorSearch:
    """Where the independent interior search ended: the box's device closest to instability at g·K."""

    point: np.ndarray
    """box values (order of box.paths)."""
    excess: float
    """spectral radius − 1 of the closed loop at (g·K, B) there (negative: stable)."""
    unstable: bool
    """the closed loop there is unstable beyond the eigenvalues' rounding bound."""
    evaluations: int


def _excess_at(box: UncertaintyBox, x: np.ndarray, gain: float, damping: float) -> tuple[float, bool]:
    dev = box.device_at(x)
    m, t = dev.mass, dev.sample_time
    plant = sampled_plant(dev)
    if plant.e.shape[0] + 1 + plant.d + (1 if plant.f > 0 else 0) > EIG_MAX_STATES:
        raise ValueError("delay too long for the eigenvalue search")
    ex = radius_excess(stiffness_closed_loop(plant, gain * t * t / m, damping * t / m))
    return ex.excess, ex.decided_unstable


def _rendered_excess_at(box: UncertaintyBox, x: np.ndarray, gain: float, damping: float, spec,
                        mass: float) -> tuple[float, bool]:
    """Spectral radius − 1 of the rendered wall's closed loop (the filter's and the virtual mass's states,
    optim.stability.closed_loop_rendered: not the rendered K_cr scan) at (gain, B) on the box's device at x."""
    from optim.stability.closed_loop_rendered import rendered_closed_loop, rendered_states

    dev = box.device_at(x)
    m, t = dev.mass, dev.sample_time
    plant = sampled_plant(dev)
    if rendered_states(plant, spec, t) > EIG_MAX_STATES:
        raise ValueError("delay too long for the eigenvalue search")
    ex = radius_excess(rendered_closed_loop(plant, spec, t, gain * t * t / m, damping * t / m, mass / m))
    return ex.excess, ex.decided_unstable


def _ff_excess_at(box: UncertaintyBox, x: np.ndarray, gain: float, order: int,
                  cutoff_hz: float) -> tuple[float, bool]:
    """Spectral radius − 1 of the force-feedforward loop 1 + K_f·D·G_1 at K_f = ``gain`` on the box's device at x
    (optim.transparency.closed_loop_feedforward: its own state matrix, the filter's states, not the K_f,cr scan)."""
    from optim.transparency.closed_loop_feedforward import feedforward_closed_loop, feedforward_loop

    dev = box.device_at(x)
    human, _ = resolve_human(dev)
    loop = feedforward_loop(dev, human, order, cutoff_hz)
    if loop.states > EIG_MAX_STATES:
        raise ValueError("delay too long for the eigenvalue search")
    ex = radius_excess(feedforward_closed_loop(loop, gain))
    return ex.excess, ex.decided_unstable


def interior_search(box: UncertaintyBox, relevant: np.ndarray, gain: float, damping: float,
                    seed: int = 20260, render: tuple | None = None) -> InteriorSearch | None:
    """The device of the box with the largest closed-loop spectral radius at the wall (gain, B), searched
    independently of the design (module doc).  None when the box's delays are too long for eigenvalues.
    ``render``: a rendered wall's (velocity filter spec, virtual mass M [kg]), closed with the filter's states."""
    if render is not None:
        spec, mass = render
        return _search(box, relevant, lambda x: _rendered_excess_at(box, x, gain, damping, spec, mass), seed)
    return _search(box, relevant, lambda x: _excess_at(box, x, gain, damping), seed)


def interior_search_inertia(box: UncertaintyBox, relevant: np.ndarray, gain: float, order: int, cutoff_hz: float,
                            seed: int = 20260) -> InteriorSearch | None:
    """The device of the box with the largest spectral radius of the force-feedforward loop at K_f = ``gain`` (the
    designed gain times 10^(GM/20): the gain the margin promises stable), searched as :func:`interior_search`."""
    return _search(box, relevant, lambda x: _ff_excess_at(box, x, gain, order, cutoff_hz), seed)


def _search(box: UncertaintyBox, relevant: np.ndarray, excess_at, seed: int) -> InteriorSearch | None:
    """The Latin hypercube and the bounded Nelder–Mead searches of the module doc on ``excess_at(x)`` → (spectral
    radius − 1, decided unstable); None when it raises ValueError (the delay too long for eigenvalues)."""
    k = int(relevant.sum())
    lo, hi = box.lower[relevant], box.upper[relevant]
    base = box.nominal_point()
    rng = np.random.default_rng(seed)
    n = INTERIOR_BASE_SAMPLES + INTERIOR_SAMPLES_PER_DIM * k
    # Latin hypercube: each axis cut into n strata, one point per stratum, strata shuffled per axis
    lhs = (np.argsort(rng.random((n, k)), axis=0) + rng.random((n, k))) / n
    evals = 0

    def point(u: np.ndarray) -> np.ndarray:
        x = base.copy()
        x[relevant] = lo + np.clip(u, 0.0, 1.0) * (hi - lo)
        return x

    def f(u: np.ndarray) -> float:
        nonlocal evals
        evals += 1
        return -excess_at(point(u))[0]

    try:
        vals = np.array([f(u) for u in lhs])
        order = np.argsort(vals)
        chosen: list[int] = []
        for i in order:
            if len(chosen) == INTERIOR_STARTS:
                break
            if all(np.max(np.abs(lhs[i] - lhs[j])) > 0.1 for j in chosen):
                chosen.append(int(i))
        best_u, best_v = lhs[order[0]], float(vals[order[0]])
        for i in chosen:
            res = minimize(f, lhs[i], method="Nelder-Mead", bounds=[(0.0, 1.0)] * k,
                           options={"maxfev": INTERIOR_MAX_EVALS_PER_DIM * k, "xatol": 1e-10, "fatol": 1e-16,
                                    "initial_simplex": _simplex(lhs[i], 1.0 / n)})
            if res.fun < best_v:
                best_u, best_v = np.clip(res.x, 0.0, 1.0), float(res.fun)
        x = point(best_u)
        excess, unstable = excess_at(x)
    except ValueError:
        return None
    return InteriorSearch(x, excess, unstable, evals + 1)


def _simplex(u: np.ndarray, width: float) -> np.ndarray:
    """A start simplex of about one stratum, pointing into the unit cube."""
    k = u.size
    s = np.repeat(u[None, :], k + 1, axis=0)
    for j in range(k):
        s[j + 1, j] += width if u[j] + width <= 1.0 else -width
    return s


def verify_robust_stiffness(box: UncertaintyBox, stiffness: float, damping: float, min_gain_margin_db: float,
                            passivity: bool, worst: dict | None = None,
                            least_passive: dict | None = None, render: tuple | None = None) -> Verification:
    """Check a robust wall (K, B) at every corner of its box and at the worst (and least passive) device found.

    ``worst`` / ``least_passive``: the design's ``worst_case["device"]`` / ``passivity_worst_case["device"]``
    (path → value).  ``render``: a rendered wall's (velocity filter spec, virtual mass M [kg]): each device's K_cr by
    the exact rendered analysis, every closed loop (the checks ± ε and the interior search) with the filter's and the
    virtual mass's states; None: today's wall."""
    t0 = time.perf_counter()
    relevant = box.relevant(STIFFNESS_PATHS)
    out = []
    extra: list[tuple[PointKind, dict | None]] = [("worst", worst), ("least passive", least_passive)]
    what = "every corner, the worst device found"
    search = None
    if relevant.any():
        search = interior_search(box, relevant, stiffness * 10.0 ** (min_gain_margin_db / 20.0), damping,
                                 render=render)
        if search is not None:
            extra.append(("interior", box.describe(search.point)))
            what += f" and the independent interior search's worst ({search.evaluations} closed loops)"
        else:
            what += " (no interior search: the delay is too long for the closed loop's eigenvalues)"
    for kind, x in _points(box, relevant, extra):
        dev = box.device_at(x)
        if render is None:
            found = critical_stiffness(dev, damping).critical_stiffness
        else:
            found = rendered_critical_stiffness(dev, damping, rendering(render[0], render[1],
                                                                        dev.sample_time)).critical_stiffness
        kcr = None if found is None or math.isinf(found) else float(found)
        # the critical gain of this device (not one implied by a margin): checked ± ε, K itself, passivity
        v = verify_stiffness_design(dev, stiffness, damping, None, True if passivity else None, critical=kcr,
                                    render=render)
        p = _point(box.describe(x), kind, kcr, stiffness, min_gain_margin_db, v)
        if kind == "interior" and search is not None and search.unstable and p.verdict != "contradicted":
            p = dataclasses.replace(p, verdict="contradicted", reason="; ".join(
                [f"the closed loop is unstable at the gain the margin promises stable, g·K = "
                 f"{stiffness * 10.0 ** (min_gain_margin_db / 20.0):.9g} N/m (|z| − 1 = {search.excess:.3g})",
                 *([p.reason] if p.reason else [])]))
        out.append(p)
    return _overall(out, t0, what)


def verify_robust_inertia(box: UncertaintyBox, force_gain: float, cutoff_hz: float, order: int,
                          min_gain_margin_db: float, worst: dict | None = None) -> Verification:
    """Check a robust force-feedforward design (K_f, cutoff) at every corner of its box, its worst device and the
    independent interior search's worst (the force-feedforward loop's spectral radius at the gain the margin promises
    stable, g·K_f, over the box: as for the stiffness design)."""
    t0 = time.perf_counter()
    out = []
    relevant = np.ones(box.dim, bool)
    extra: list[tuple[PointKind, dict | None]] = [("worst", worst)]
    what = "every corner, the worst device found"
    gained = force_gain * 10.0 ** (min_gain_margin_db / 20.0)
    search = interior_search_inertia(box, relevant, gained, order, cutoff_hz) if box.dim else None
    if search is not None:
        extra.append(("interior", box.describe(search.point)))
        what += f" and the independent interior search's worst ({search.evaluations} closed loops)"
    elif box.dim:
        what += " (no interior search: the delay is too long for the closed loop's eigenvalues)"
    for kind, x in _points(box, relevant, extra):
        dev: Device = box.device_at(x)
        human, _ = resolve_human(dev)
        filt = ButterworthLowPass(order=order, cutoff_hz=cutoff_hz, sample_time=dev.sample_time)
        kcr = float(critical_force_gain(dev, filt, human).critical_force_gain)
        kcr_or_none = None if math.isinf(kcr) else kcr
        v = verify_critical_force_gain(dev, human, kcr_or_none, order, cutoff_hz, design_gain=force_gain)
        p = _point(box.describe(x), kind, kcr_or_none, force_gain, min_gain_margin_db, v)
        if kind == "interior" and search is not None and search.unstable and p.verdict != "contradicted":
            p = dataclasses.replace(p, verdict="contradicted", reason="; ".join(
                [f"the closed loop is unstable at the gain the margin promises stable, g·K_f = {gained:.9g} "
                 f"(|z| − 1 = {search.excess:.3g})", *([p.reason] if p.reason else [])]))
        out.append(p)
    return _overall(out, t0, what)
