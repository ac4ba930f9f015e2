"""Transparency design: force-feedforward gain K_f and filter cutoff (chapter §5.2).

Two objectives over (K_f, f_c), f_c in [cutoff_min_hz, cutoff_max_hz] (the human
force bandwidth, ~10 Hz, and the first vibration mode, eq. 24), with the gain
margin 20·log10(K_f,cr(f_c)/K_f) ≥ min_gain_margin_db:

* ``min_apparent_mass``: the largest K_f (lightest feel m/(1 + K_f));
* ``target_apparent_mass``: K_f = m/m_target - 1 and the highest cutoff that keeps
  the margin (the chapter matched 0.9 kg with K_f = 5 at 30 Hz).

Method: an exact scan of K_f,cr over the band (the Pareto curve "best K_f for
each cutoff"), densified and with every change of the crossover structure
bracketed on both sides (optim/transparency/inertia_band.py: K_f,cr jumps where a crossover
pair appears tangentially), brackets the optimum; a CasADi/Ipopt solve of the
crossover conditions (optim/transparency/inertia_nlp.py) refines each promising local maximum
inside its piece of constant structure; every crossover the exact analysis
finds at the solve's cutoff joins the tracked set and the solve is repeated
until the exact analysis agrees (exchange method).  A target's boundary at a
jump is bisected on the exact verdict.
The reported K_f,cr, margin and crossover are the exact analysis's.  With a
range of grasps the design holds for the worst of them: the masses evaluated
are refined by the same exchange (a dense exact check over the range adds the
worst mass found until none violates).  A cable device is designed with its
two-mass model, and the rigid model's claim at the same cutoff is reported.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Literal

import numpy as np

from models.device import Device, Human
from optim.solver_info import NO_SOLVER, SolverInfo
from optim.transparency.feedforward_loop import (
    RIGID_OPTIMISM_FLAG,
    FeedforwardLoop,
    RigidComparison,
    cutoff_band,
    design_humans,
    rigid_comparison,
    upper_cutoff_hz,
)
from optim.transparency.inertia_band import BandAnswer, BandProfile, band_profile, highest_feasible, maximise
from optim.transparency.inertia_nlp import modal_plant
from optim.transparency.inertia_requirements import InertiaRequirements

__all__ = ["InertiaRequirements", "ParetoPoint", "RigidComparison", "InertiaDesign", "design_inertia",
           "upper_cutoff_hz", "pareto_points", "RIGID_OPTIMISM_FLAG"]

_MAX_HUMAN_ROUNDS = 3
_RANGE_CHECK_MASSES = 33     # dense exact check of the final design over the range
_MODAL_RTOL = 1e-8           # the NLP's modal G_1 must match the exact response this well
_NO_CROSSOVER = "no phase crossover at some cutoff: the model bounds no force gain there"
_NOT_CONVERGED = "Ipopt did not converge on the crossover conditions"


@dataclass(frozen=True)
class ParetoPoint:
    filter_cutoff_hz: float
    critical_force_gain: float
    """K_f,cr at this cutoff, worst grasp [dimensionless]."""
    force_gain: float
    """Best K_f with the required margin, K_f,cr/10^{GM/20}."""
    apparent_mass: float
    """m/(1 + force_gain) [kg]."""


@dataclass(frozen=True)
class InertiaDesign:
    status: Literal["optimal", "infeasible", "failed", "unsafe"]
    """unsafe: a design of an approximate rung (linear, grid) that fails its own exact check (optim.design_ladder)."""
    objective: Literal["min_apparent_mass", "target_apparent_mass"]
    force_gain: float | None
    filter_cutoff_hz: float | None
    filter_order: int
    apparent_mass: float | None
    """m/(1 + K_f) [kg]."""
    critical_force_gain: float | None
    gain_margin_db: float | None
    crossover_frequency: float | None
    """ω [rad/s] of the crossover that sets K_f,cr at the design's cutoff."""
    cutoff_band_hz: tuple[float, float]
    cutoff_max_source: str
    pareto: tuple[ParetoPoint, ...]
    humans: tuple[Human, ...]
    worst_human: Human | None
    human_source: str
    rigid_model: RigidComparison | None
    solver: SolverInfo = NO_SOLVER
    """Ipopt's statistics (or the exact step that decided), and the band's crossover_structure_changes_hz."""
    reason: str | None = None
    elapsed_ms: float = 0.0


def pareto_points(cutoffs_hz: np.ndarray, kcrs: np.ndarray, rho: float, mass: float) -> tuple[ParetoPoint, ...]:
    """The exact scan of the band as Pareto points: K_f,cr per cutoff, the K_f it allows with the margin
    ρ = 10^{GM/20}, and the apparent mass m/(1 + K_f)."""
    return tuple(ParetoPoint(float(c), float(k), float(k / rho), float(mass / (1 + k / rho)))
                 for c, k in zip(cutoffs_hz, kcrs))


def design_inertia(device: Device, req: InertiaRequirements | None = None) -> InertiaDesign:
    """Design K_f and the filter cutoff (see module docstring); ValueError names a bad requirement."""
    start = time.perf_counter()
    req = req or InertiaRequirements()
    lo_hz, hi_hz, hi_src = cutoff_band(device, req)
    humans, human_src = design_humans(device, req)
    for _ in range(_MAX_HUMAN_ROUNDS):
        design = _design(device, req, humans, human_src, lo_hz, hi_hz, hi_src)
        extra = _range_violation(device, req, humans, design)
        if extra is None:
            break
        humans = humans + [extra]
    else:
        design = _replace(design, status="failed", reason="the worst grasp in the mass range did not settle")
    return _replace(design, elapsed_ms=(time.perf_counter() - start) * 1e3)


def _replace(design: InertiaDesign, **kw) -> InertiaDesign:
    return InertiaDesign(**{**design.__dict__, **kw})


def _range_violation(device: Device, req: InertiaRequirements, humans: list[Human],
                     design: InertiaDesign) -> Human | None:
    """A grasp mass in the range whose K_f,cr at the design's cutoff is below the design's."""
    if req.human_mass_range is None or design.status != "optimal":
        return None
    lo, hi = req.human_mass_range.min, req.human_mass_range.max
    base = humans[0]
    dense = [base.model_copy(update={"mass": float(m)}) for m in np.geomspace(lo, hi, _RANGE_CHECK_MASSES)]
    loop = FeedforwardLoop(device, dense, req.filter_order)
    kcr, _, who, _ = loop.exact(2 * math.pi * design.filter_cutoff_hz * device.sample_time)
    if kcr < design.critical_force_gain * (1 - 1e-9):
        return dense[who]
    return None


@dataclass(frozen=True)
class _Search:
    """What both objectives search: the exact loop over the grasps, its profile over the band and the modal plants
    of the crossover NLP."""

    device: Device
    req: InertiaRequirements
    humans: list[Human]
    loop: FeedforwardLoop
    rho: float
    """10^{GM/20}: K_f,cr over K_f at the required margin."""
    t_of: float
    """cutoff angle per Hz [rad/sample per Hz]."""
    band_hz: tuple[float, float]
    edges: tuple[float, float]
    """the band's ends as angles (an answer there reports the cutoff in Hz as given)."""
    profile: BandProfile
    modal: list
    common: dict
    """the fields every answer shares (objective, band, Pareto scan, grasps)."""
    solver: SolverInfo


def _design(device: Device, req: InertiaRequirements, humans: list[Human], human_src: str,
            lo_hz: float, hi_hz: float, hi_src: str) -> InertiaDesign:
    """The design for one set of grasps: the band's exact scan, then the objective's own search."""
    search = _search(device, req, humans, human_src, lo_hz, hi_hz, hi_src)
    if isinstance(search, InertiaDesign):
        return search
    if req.target_apparent_mass is None:
        return _min_apparent_mass(search)
    return _target_apparent_mass(search)


def _search(device: Device, req: InertiaRequirements, humans: list[Human], human_src: str,
            lo_hz: float, hi_hz: float, hi_src: str) -> _Search | InertiaDesign:
    """The exact scan of the band (the Pareto points), its profile and modal plants; or an answer when the band
    has no crossover or the crossover model cannot be built."""
    t_of = 2 * math.pi * device.sample_time
    loop = FeedforwardLoop(device, humans, req.filter_order)
    rho = 10 ** (req.min_gain_margin_db / 20)
    cutoffs = np.geomspace(lo_hz, hi_hz, max(2, req.pareto_points))
    kcrs = np.array([loop.exact(c * t_of)[0] for c in cutoffs])
    objective = "target_apparent_mass" if req.target_apparent_mass is not None else "min_apparent_mass"
    common = dict(objective=objective, filter_order=req.filter_order, cutoff_band_hz=(lo_hz, hi_hz),
                  cutoff_max_source=hi_src, pareto=pareto_points(cutoffs, kcrs, rho, device.mass),
                  humans=tuple(humans), human_source=human_src)
    solver = SolverInfo("ipopt (CasADi), exchange method, exact re-check")
    if not np.all(np.isfinite(kcrs)):
        return _empty("infeasible", solver, common, _NO_CROSSOVER)
    modal = []
    for plant in loop.plants:
        mp, err = modal_plant(plant)
        if not err <= _MODAL_RTOL:
            solver = SolverInfo(solver.name, f"modal form of G_1 off by {err:.2g} (ill-conditioned eigenvectors of A)")
            return _empty("failed", solver, common, "the crossover model could not be built accurately")
        modal.append(mp)
    profile = band_profile(loop, cutoffs * t_of)
    if profile.jumps:
        solver = solver.with_details(crossover_structure_changes_hz=[[lo / t_of, hi / t_of]
                                                                     for lo, hi in profile.jumps])
    if not np.all(np.isfinite(profile.kcrs)):
        return _empty("infeasible", solver, common, _NO_CROSSOVER)
    return _Search(device, req, humans, loop, rho, t_of, (lo_hz, hi_hz), (cutoffs[0] * t_of, cutoffs[-1] * t_of),
                   profile, modal, common, solver)


def _with_stats(solver: SolverInfo, found: BandAnswer) -> SolverInfo:
    """The search's record with the statistics of the solve that decided the answer."""
    stats = found.stats
    named = {k: stats[k] for k in ("return_status", "iterations", "starts") if k in stats}
    rest = {k: v for k, v in stats.items() if k not in named}
    return SolverInfo(solver.name, **{"return_status": solver.return_status, **named}).with_details(
        **dict(solver.details), **rest)


def _answer(s: _Search, status: Literal["optimal", "infeasible"], kf: float, theta: float, solver: SolverInfo,
            reason: str | None = None) -> InertiaDesign:
    """The design at cutoff angle θ, with the exact K_f,cr, margin and crossover there."""
    # at θ itself: a cutoff next to a jump of K_f,cr must not round across it
    kcr, th, who, _ = s.loop.exact(theta)
    cutoff_hz = {s.edges[0]: s.band_hz[0], s.edges[1]: s.band_hz[1]}.get(theta, theta / s.t_of)  # the edges as given
    return InertiaDesign(status=status, force_gain=kf, filter_cutoff_hz=cutoff_hz,
                         apparent_mass=s.device.mass / (1 + kf), critical_force_gain=kcr, gain_margin_db=20 * math.log10(kcr / kf) if kf > 0 else None,
                         crossover_frequency=None if th is None else th / s.device.sample_time,
                         worst_human=s.humans[who],
                         rigid_model=rigid_comparison(s.device, s.humans, s.req.filter_order, cutoff_hz, kcr, s.rho),
                         solver=solver, reason=reason, **s.common)


def _min_apparent_mass(s: _Search) -> InertiaDesign:
    """The largest K_f over the band: every promising local maximum refined (inertia_band.maximise)."""
    found = maximise(s.loop, s.profile, s.modal, math.log(s.rho))
    solver = _with_stats(s.solver, found)
    if found.failed:
        return _empty("failed", solver, s.common, _NOT_CONVERGED)
    return _answer(s, "optimal", s.loop.exact(found.theta)[0] / s.rho, found.theta, solver)


def _target_apparent_mass(s: _Search) -> InertiaDesign:
    """K_f = m/m_target − 1 at the highest cutoff that keeps the margin (inertia_band.highest_feasible)."""
    req, m, rho = s.req, s.device.mass, s.rho
    kf = m / req.target_apparent_mass - 1.0
    if kf <= 0.0:
        return InertiaDesign(status="infeasible", force_gain=0.0, filter_cutoff_hz=None, apparent_mass=m,
                             critical_force_gain=None, gain_margin_db=None, crossover_frequency=None,
                             worst_human=None, rigid_model=None, solver=s.solver,
                             reason=f"target_apparent_mass {req.target_apparent_mass:g} is not below the device's "
                                    f"mass {m:g}: force feedforward only lowers the apparent mass", **s.common)
    found = highest_feasible(s.loop, s.profile, s.modal, math.log(rho), rho * kf)
    solver = _with_stats(s.solver, found)
    if found.failed:
        return _empty("failed", solver, s.common, _NOT_CONVERGED)
    if found.theta is None:
        th_best, k_best = found.best
        best = k_best / rho
        lo_hz, hi_hz = s.band_hz
        return _answer(s, "infeasible", best, th_best, solver,
                       f"K_f = {kf:.6g} (apparent mass {req.target_apparent_mass:g}) needs K_f,cr ≥ {rho * kf:.6g} "
                       f"for {req.min_gain_margin_db:g} dB, but the largest K_f,cr in [{lo_hz:g}, {hi_hz:g}] Hz is "
                       f"{k_best:.6g} at {th_best / s.t_of:.4g} Hz; the best reachable with the margin is "
                       f"K_f = {best:.6g}, apparent mass {m / (1 + best):.6g}")
    return _answer(s, "optimal", kf, found.theta, solver)


def _empty(status: Literal["infeasible", "failed"], solver: SolverInfo, common: dict, reason: str) -> InertiaDesign:
    """An answer without a design (no crossover, or the crossover model or its NLP failed)."""
    return InertiaDesign(status=status, force_gain=None, filter_cutoff_hz=None, apparent_mass=None,
                         critical_force_gain=None, gain_margin_db=None, crossover_frequency=None,
                         worst_human=None, rigid_model=None, solver=solver, reason=reason, **common)
