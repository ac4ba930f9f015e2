"""Robust inertia design: one force-feedforward gain K_f and filter cutoff that hold for every device of a box.

The chapter's §5 loop 1 + K_f·D(z)·G_1(z) = 0 depends on the device (mass,
damping, delay, cable), the user's grasp and the force sensor, so every path
of the box may move K_f,cr.  Scenario exchange, as for the stiffness
(optim/robust/stiffness.py):

1. scenarios: the nominal device (clipped into the box) and every corner, each with
   its grasp (the device's human block, else the chapter's eq. 30);
2. the design over the scenarios is optim.transparency.inertia's own method with the scenarios
   in place of its grasps: an exact Pareto scan of min_s K_f,cr(f_c; s) over the
   band, then its CasADi crossover NLP (optim.transparency.inertia_nlp) with one margin
   constraint per scenario crossover, and its exchange of crossovers;
3. the whole box is searched for the device with the smallest K_f,cr at the
   design's cutoff (Sobol + corners + pattern search, exact analysis);
4. a device short of the margin by more than 1e-6 dB becomes a scenario.
The gain is finally clipped to K_f,cr(worst)/10^{GM/20}.

The filter is one cutoff f_c in Hz; each device discretises it with its own sample
time (bilinear, prewarped at the cutoff), so scenario s sees the cutoff angle
θ_s = 2π f_c T_s = θ_ref·T_s/T_ref (T_ref: the nominal device's).  The scan, the
NLP (one cutoff variable θ_ref, a scale T_s/T_ref per crossover) and the
worst-case search all carry each device's own angle.  The upper cutoff defaults
to the lowest first cable mode, or 0.4 × Nyquist, over the box's corners (eq. 24).

Besides the worst device the answer carries the scan of the last round as
``pareto`` (best K_f per cutoff, worst over the *scenarios*: the design's own
cutoff alone is verified over the whole box) and, with a cable block, what the
rigid model of the worst device claims at the design's cutoff.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from models.device import Device
from models.feedforward import feedforward_plant
from optim.errors import InputError
from optim.robust.box import UncertaintyBox
from optim.robust.stiffness import TOLERANCE_DB
from optim.robust.worst_case import minimise_over_box
from optim.solver_info import NO_SOLVER, SolverInfo
from optim.transparency.feedforward import resolve_human
from optim.transparency.feedforward_loop import FeedforwardLoop, RigidComparison, cutoff_band, rigid_comparison
from optim.transparency.inertia import InertiaRequirements, ParetoPoint, pareto_points
from optim.transparency.inertia_band import band_profile, highest_feasible, maximise
from optim.transparency.inertia_nlp import modal_plant

__all__ = ["RobustInertiaDesign", "robust_design_inertia"]

_MAX_OUTER = 12
_MODAL_RTOL = 1e-8


@dataclass(frozen=True)
class RobustInertiaDesign:
    status: Literal["optimal", "infeasible", "failed"]
    objective: Literal["min_apparent_mass", "target_apparent_mass"]
    force_gain: float | None = None
    filter_cutoff_hz: float | None = None
    filter_order: int = 2
    apparent_mass: float | None = None
    """m/(1 + K_f) of the nominal device [kg]."""
    apparent_mass_range: tuple[float, float] | None = None
    """m/(1 + K_f) over the box's masses [kg]."""
    critical_force_gain: float | None = None
    """K_f,cr of the worst device at the design's cutoff."""
    gain_margin_db: float | None = None
    """worst-case 20·log10(K_f,cr/K_f) over the box [dB]."""
    worst_case: dict | None = None
    nominal_gain_margin_db: float | None = None
    cutoff_band_hz: tuple[float, float] | None = None
    pareto: tuple[ParetoPoint, ...] = ()
    """the last round's scan: K_f,cr per cutoff, worst over the scenarios (an upper bound of the box's worst
    except at the design's cutoff, which the box search verifies)."""
    rigid_model: RigidComparison | None = None
    """with a cable block: the rigid model of the worst device at the design's cutoff."""
    scenarios: tuple[dict, ...] = ()
    iterations: int = 0
    evaluations: int = 0
    reason: str | None = None
    solver: SolverInfo = NO_SOLVER
    """the statistics of the last solves that decided (Ipopt's or the exact step's), and the band's jumps."""
    elapsed_ms: float = 0.0


class _ScenarioLoop(FeedforwardLoop):
    """optim.transparency.inertia's worst-grasp loop with one plant per scenario device, each at its own cutoff angle
    θ_ref·T_s/T_ref (the cutoff is one frequency in Hz)."""

    def __init__(self, devices: list[Device], order: int, t_ref: float):
        self.plants, self.order, self._memo = [_plant(d) for d in devices], order, {}
        self.cutoff_scales = [d.sample_time / t_ref for d in devices]


@dataclass(frozen=True)
class _Step:
    force_gain: float
    theta: float
    """the cutoff angle at T_ref [rad per sample]."""
    pareto: tuple[ParetoPoint, ...]
    stats: dict = field(default_factory=dict)
    """this round's solver statistics (the band's jumps, the deciding solve's)."""


def _plant(device: Device):
    human, _ = resolve_human(device)
    return feedforward_plant(device, human)


def robust_design_inertia(nominal: Device, req: InertiaRequirements, box: UncertaintyBox) -> RobustInertiaDesign:
    t0 = time.perf_counter()
    if req.humans is not None or req.human_mass_range is not None:
        raise InputError("requirements.uncertainty", "give the grasp's range as device.human.mass (with a human "
                         "block), not together with humans or human_mass_range")
    corners = box.devices(box.corners())
    bands = [cutoff_band(d, req) for d in [box.device_at(box.nominal_point()), *corners]]
    lo_hz, hi_hz = bands[0][0], min(b[1] for b in bands)
    if not lo_hz < hi_hz:
        raise InputError("requirements.cutoff_min_hz", f"must be below the lowest upper cutoff of the box {hi_hz:g} Hz")
    rho = 10 ** (req.min_gain_margin_db / 20)
    t_ref = nominal.sample_time
    t_of = 2 * math.pi * t_ref
    active = np.array([hi > lo for lo, hi in zip(box.lower, box.upper)])
    points = [box.nominal_point()] + [c for c in box.corners()]
    points = list(np.unique(np.array(points), axis=0))
    objective = "target_apparent_mass" if req.target_apparent_mass is not None else "min_apparent_mass"
    evals, step = 0, None
    stats: dict = {}
    for it in range(1, _MAX_OUTER + 1):
        loop = _ScenarioLoop(box.devices(np.array(points)), req.filter_order, t_ref)
        out = _design(loop, req, rho, lo_hz, hi_hz, t_of, nominal.mass, objective)
        if isinstance(out, RobustInertiaDesign):
            return _with(out, t0, it, evals, box, points, lo_hz, hi_hz)
        # a later round's statistics replace an earlier round's, key by key (a key it does not set stays)
        stats = {**stats, **out.stats}
        step, theta = out, out.theta

        def evaluate(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            vals = [_ScenarioLoop([box.device_at(x)], req.filter_order, t_ref).exact(theta) for x in box.to_box(u)]
            return np.array([v[0] for v in vals]), np.array([v[1] if v[1] is not None else np.nan for v in vals])

        wu, wk, wa, n = minimise_over_box(box, active, evaluate, samples=64, starts=2, seed=it)
        evals += n
        margin = 20 * math.log10(wk / step.force_gain) if wk > 0 else -math.inf
        if margin >= req.min_gain_margin_db - TOLERANCE_DB:
            break
        wp = box.to_box(wu)
        if any(np.array_equal(wp, p) for p in points):
            return _with(RobustInertiaDesign(status="failed", objective=objective, reason=(
                "the worst device is already a scenario but the design misses its margin")), t0, it, evals, box,
                points, lo_hz, hi_hz)
        points.append(wp)
    else:
        return _with(RobustInertiaDesign(status="failed", objective=objective,
                                         reason=f"the scenario exchange did not settle in {_MAX_OUTER} rounds"),
                     t0, it, evals, box, points, lo_hz, hi_hz)
    kf = min(step.force_gain, wk / rho)
    cutoff_hz = step.theta / t_of
    wdev = box.device_at(box.to_box(wu))
    nom = _ScenarioLoop([box.device_at(box.nominal_point())], req.filter_order, t_ref).exact(step.theta)[0]
    masses = [d.mass for d in corners] + [nominal.mass]
    worst = {"device": box.describe(box.to_box(wu)), "critical_force_gain": wk,
             "crossover_frequency": None if not math.isfinite(wa) else wa / wdev.sample_time,
             "gain_margin_db": 20 * math.log10(wk / kf)}
    rigid = rigid_comparison(wdev, [resolve_human(wdev)[0]], req.filter_order, cutoff_hz, wk, rho)
    d = RobustInertiaDesign(
        status="optimal", objective=objective, force_gain=kf, filter_cutoff_hz=cutoff_hz,
        filter_order=req.filter_order, apparent_mass=nominal.mass / (1 + kf),
        apparent_mass_range=(min(masses) / (1 + kf), max(masses) / (1 + kf)), critical_force_gain=wk,
        gain_margin_db=worst["gain_margin_db"], worst_case=worst, nominal_gain_margin_db=20 * math.log10(nom / kf),
        pareto=step.pareto, rigid_model=rigid, solver=SolverInfo.from_stats(None, stats))
    return _with(d, t0, it, evals, box, points, lo_hz, hi_hz)


def _with(d: RobustInertiaDesign, t0, it, evals, box, points, lo_hz, hi_hz) -> RobustInertiaDesign:
    return RobustInertiaDesign(**{**d.__dict__, "iterations": it, "evaluations": evals,
                                  "scenarios": tuple(box.describe(p) for p in points),
                                  "cutoff_band_hz": (lo_hz, hi_hz), "elapsed_ms": (time.perf_counter() - t0) * 1e3})


def _design(loop: _ScenarioLoop, req, rho, lo_hz, hi_hz, t_of, mass, objective) -> _Step | RobustInertiaDesign:
    """A _Step (K_f, θ_ref, the scan) over the current scenarios (optim.transparency.inertia's method and band search,
    optim/transparency/inertia_band.py), or a finished design (infeasible/failed)."""
    cutoffs = np.geomspace(lo_hz, hi_hz, max(2, req.pareto_points))
    t = cutoffs * t_of
    kcrs = np.array([loop.exact(th)[0] for th in t])
    no_crossover = "no phase crossover at some cutoff: the model bounds no force gain there"
    if not np.all(np.isfinite(kcrs)):
        return RobustInertiaDesign(status="infeasible", objective=objective, reason=no_crossover)
    pareto = pareto_points(cutoffs, kcrs, rho, mass)
    if objective == "target_apparent_mass":
        kf = mass / req.target_apparent_mass - 1.0
        if kf <= 0.0:
            return RobustInertiaDesign(status="infeasible", objective=objective, pareto=pareto, reason=(
                f"target_apparent_mass {req.target_apparent_mass:g} is not below the nominal mass {mass:g}"))
    modal = []
    for plant in loop.plants:
        mp, err = modal_plant(plant)
        if not err <= _MODAL_RTOL:
            return RobustInertiaDesign(status="failed", objective=objective, pareto=pareto,
                                       reason=f"modal form of G_1 off by {err:.2g} (ill-conditioned eigenvectors of A)")
        modal.append(mp)
    profile = band_profile(loop, t)
    if not np.all(np.isfinite(profile.kcrs)):
        return RobustInertiaDesign(status="infeasible", objective=objective, pareto=pareto, reason=no_crossover)
    jumps = {"crossover_structure_changes_hz": [[lo / t_of, hi / t_of] for lo, hi in profile.jumps]} \
        if profile.jumps else {}
    if objective == "target_apparent_mass":
        found = highest_feasible(loop, profile, modal, math.log(rho), rho * kf)
        if found.failed:
            return RobustInertiaDesign(status="failed", objective=objective, pareto=pareto,
                                       reason="Ipopt did not converge on the crossover conditions")
        if found.theta is None:
            th_best, k_best = found.best
            best = k_best / rho
            return RobustInertiaDesign(status="infeasible", objective=objective, force_gain=best, pareto=pareto,
                                       filter_cutoff_hz=th_best / t_of, reason=(
                                           f"K_f = {kf:.6g} needs K_f,cr ≥ {rho * kf:.6g} on every scenario device, "
                                           f"but their largest K_f,cr in [{lo_hz:g}, {hi_hz:g}] Hz is {k_best:.6g} "
                                           f"at {th_best / t_of:.4g} Hz; the best reachable is K_f = {best:.6g}"))
        return _Step(kf, found.theta, pareto, {**jumps, **found.stats})
    found = maximise(loop, profile, modal, math.log(rho))
    if found.failed:   # the scan's best sample, unrefined, is still a valid design: the box search verifies it
        theta = found.best[0]
        stats = {**jumps, **found.stats,
                 "return_status": "scan point kept: Ipopt did not converge on the crossover conditions"}
    else:
        theta, stats = found.theta, {**jumps, **found.stats}
    return _Step(loop.exact(theta)[0] / rho, theta, pareto, stats)
