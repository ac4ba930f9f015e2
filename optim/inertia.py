"""Transparency design: force-feedforward gain K_f and filter cutoff (chapter §5.2).

Two objectives over (K_f, f_c), f_c in [cutoff_min_hz, cutoff_max_hz] (the human
force bandwidth, ~10 Hz, and the first vibration mode, eq. 24), with the gain
margin 20·log10(K_f,cr(f_c)/K_f) ≥ min_gain_margin_db:

* ``min_apparent_mass``: the largest K_f (lightest feel m/(1 + K_f));
* ``target_apparent_mass``: K_f = m/m_target - 1 and the highest cutoff that keeps
  the margin (the chapter matched 0.9 kg with K_f = 5 at 30 Hz).

Method: an exact scan of K_f,cr over the band (the Pareto curve "best K_f for
each cutoff") brackets the optimum; a CasADi/Ipopt solve of the crossover
conditions (optim/inertia_nlp.py) refines it inside the bracket; every
crossover the exact analysis finds at the solve's cutoff joins the tracked set
and the solve is repeated until the exact analysis agrees (exchange method).
The reported K_f,cr, margin and crossover are the exact analysis's.  With a
range of grasps the design holds for the worst of them: the masses evaluated
are refined by the same exchange (a dense exact check over the range adds the
worst mass found until none violates).  A cable device is designed with its
two-mass model, and the rigid model's claim at the same cutoff is reported.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import brentq

from models.device import Device, Human
from models.feedforward import feedforward_plant
from models.filters import MAX_FILTER_ORDER

from .feedforward import critical_force_gain_of_plant, resolve_human
from .inertia_nlp import modal_plant, solve_crossover_nlp
from .errors import InputError

__all__ = ["InertiaRequirements", "ParetoPoint", "RigidComparison", "InertiaDesign", "design_inertia",
           "upper_cutoff_hz", "pareto_points", "RIGID_OPTIMISM_FLAG"]

#: Flag the rigid model when its critical K_f exceeds the cable model's by more than this.
RIGID_OPTIMISM_FLAG = 0.20
_MAX_EXCHANGE_ROUNDS = 6
_MAX_HUMAN_ROUNDS = 3
_RANGE_START_MASSES = 5      # grasp masses a range starts with (geometric, ends included)
_RANGE_CHECK_MASSES = 33     # dense exact check of the final design over the range
_MODAL_RTOL = 1e-8           # the NLP's modal G_1 must match the exact response this well


@dataclass(frozen=True)
class InertiaRequirements:
    min_gain_margin_db: float = 6.0
    """Required 20·log10(K_f,cr/K_f) [dB]."""
    cutoff_min_hz: float = 10.0
    """Lowest filter cutoff [Hz]: the human force bandwidth (Lawrence et al., §5.2)."""
    cutoff_max_hz: float | None = None
    """Highest cutoff [Hz]; default the first cable mode ω_n/2π (eq. 24), else 0.4 × Nyquist."""
    filter_order: int = 2
    """Butterworth order, 1-4 (the chapter: 2)."""
    target_apparent_mass: float | None = None
    """m_target [kg]: reach it and keep the highest cutoff, instead of minimising the mass."""
    human_mass_range: tuple[float, float] | None = None
    """(min, max) grasp mass m_h [kg] (finger ... arm); damping and stiffness of the base grasp."""
    humans: tuple[Human, ...] | None = None
    """An explicit list of grasps; the design holds for the worst."""
    pareto_points: int = 17
    """Cutoffs of the exact Pareto scan over the band (geometric)."""


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
class RigidComparison:
    critical_force_gain: float
    """What the rigid model (m = m_r + m_d) claims K_f,cr is at the design's cutoff."""
    force_gain: float
    """The K_f it would have allowed with the required margin."""
    optimism: float
    """K_f,cr(rigid)/K_f,cr(cable) - 1."""
    optimistic: bool
    """optimism > 20 %: the rigid model would have over-promised."""


@dataclass(frozen=True)
class InertiaDesign:
    status: str
    """optimal | infeasible | failed."""
    objective: str
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
    solver: dict = field(default_factory=dict)
    reason: str | None = None
    elapsed_ms: float = 0.0


def pareto_points(cutoffs_hz: np.ndarray, kcrs: np.ndarray, rho: float, mass: float) -> tuple[ParetoPoint, ...]:
    """The exact scan of the band as Pareto points: K_f,cr per cutoff, the K_f it allows with the margin
    ρ = 10^{GM/20}, and the apparent mass m/(1 + K_f)."""
    return tuple(ParetoPoint(float(c), float(k), float(k / rho), float(mass / (1 + k / rho)))
                 for c, k in zip(cutoffs_hz, kcrs))


def upper_cutoff_hz(device: Device, cutoff_max_hz: float | None = None) -> tuple[float, str]:
    """The top of the cutoff band [Hz] and where it comes from: ``cutoff_max_hz`` when given, else the
    first cable mode ω_n/2π (eq. 24) when it lies below Nyquist, else 0.4 × Nyquist."""
    nyq = 0.5 / device.sample_time
    if cutoff_max_hz is not None:
        return cutoff_max_hz, "requirements"
    if device.cable is not None and device.cable.natural_frequency / (2 * math.pi) < nyq:
        return device.cable.natural_frequency / (2 * math.pi), "first cable mode ω_n/2π (eq. 24)"
    return 0.4 * nyq, "0.4 × Nyquist (no cable mode below Nyquist)"


def _band(device: Device, req: InertiaRequirements) -> tuple[float, float, str]:
    nyq = 0.5 / device.sample_time
    hi, src = upper_cutoff_hz(device, req.cutoff_max_hz)
    if not hi < nyq:
        raise InputError("requirements.cutoff_max_hz", f"must be below the Nyquist frequency {nyq:g} Hz, got {hi:g}")
    if not req.cutoff_min_hz < hi:
        raise InputError("requirements.cutoff_min_hz", f"must be below the upper cutoff {hi:g} Hz ({src}), "
                         f"got {req.cutoff_min_hz:g}")
    return req.cutoff_min_hz, hi, src


def _humans(device: Device, req: InertiaRequirements) -> tuple[list[Human], str]:
    if req.humans:
        return list(req.humans), "requirements.humans"
    base, src = resolve_human(device)
    if req.human_mass_range is None:
        return [base], src
    lo, hi = req.human_mass_range
    masses = np.geomspace(lo, hi, _RANGE_START_MASSES) if hi > lo else [lo]
    return [base.model_copy(update={"mass": float(m)}) for m in masses], \
        f"requirements.human_mass_range with damping/stiffness of {src}"


class _Loop:
    """The exact K_f,cr(θ_c) of one device over a set of grasps (worst grasp).

    ``cutoff_scales[j]`` maps θ_c to plant j's own cutoff angle (1 here: one device, one sample time;
    optim.robust.inertia's devices of other sample times see the same cutoff in Hz at θ_c·T_j/T_ref).
    """

    def __init__(self, device: Device, humans: list[Human], order: int):
        self.device, self.humans, self.order = device, humans, order
        self.plants = [feedforward_plant(device, h) for h in humans]
        self.cutoff_scales = [1.0] * len(self.plants)
        self._memo: dict[float, tuple] = {}

    def exact(self, theta_c: float) -> tuple[float, float | None, int, list[tuple[int, float]]]:
        """(K_f,cr, θ of its crossover, index of the worst grasp, every (grasp, θ) crossover)."""
        theta_c = float(theta_c)
        if theta_c not in self._memo:
            self._memo[theta_c] = self._exact(theta_c)
        return self._memo[theta_c]

    def structure(self, theta_c: float) -> tuple[int, ...]:
        """How many crossovers each grasp's loop has at this cutoff."""
        found = self.exact(theta_c)[3]
        return tuple(sum(1 for j, _ in found if j == i) for i in range(len(self.plants)))

    def _exact(self, theta_c: float) -> tuple[float, float | None, int, list[tuple[int, float]]]:
        best, where, who, found = math.inf, None, 0, []
        for j, plant in enumerate(self.plants):
            k, th, pairs = critical_force_gain_of_plant(plant, theta_c * self.cutoff_scales[j], self.order)
            found += [(j, a) for a, _ in pairs]
            if k < best:
                best, where, who = k, th, j
        return best, where, who, found


def _merge(tracked: list[tuple[int, float]], new: list[tuple[int, float]]) -> list[tuple[int, float]]:
    out = list(tracked)
    for j, a in new:
        if not any(j == jj and abs(a - aa) <= 1e-6 * a for jj, aa in out):
            out.append((j, a))
    return out


def _refine(loop: _Loop, modal, log_rho: float, t0: float, bounds: tuple[float, float],
            objective: str, y_fixed: float, info: dict) -> float | None:
    """Exchange method: local NLP solves until the exact analysis agrees; returns θ_c or None (failed)."""
    k0, _, _, tracked = loop.exact(t0)
    y0 = math.log(k0) - log_rho if objective == "max_gain" else y_fixed
    for rounds in range(1, _MAX_EXCHANGE_ROUNDS + 1):
        res = solve_crossover_nlp(modal, tracked, loop.order, log_rho, t0, bounds, y0, objective, y_fixed,
                                  cutoff_scales=loop.cutoff_scales)
        info.update(return_status=res.return_status, exchange_rounds=rounds,
                    tracked_crossovers=len(tracked))
        if not res.success:
            return None
        # Ipopt may relax a bound by ~1e-8 (bound_relax_factor): the band is a hard limit.
        theta = min(max(res.cutoff_angle, bounds[0]), bounds[1])
        kcr, _, _, found = loop.exact(theta)
        gain = math.exp(res.log_gain + log_rho)
        if gain <= kcr * (1 + 1e-8):
            return theta
        tracked = _merge(tracked, found)
    info["return_status"] = "exchange did not settle"
    return None


def design_inertia(device: Device, req: InertiaRequirements | None = None) -> InertiaDesign:
    """Design K_f and the filter cutoff (see module docstring); ValueError names a bad requirement."""
    start = time.perf_counter()
    req = req or InertiaRequirements()
    if not 1 <= req.filter_order <= MAX_FILTER_ORDER:
        raise InputError("requirements.filter_order", f"must be 1-{MAX_FILTER_ORDER}, got {req.filter_order}")
    lo_hz, hi_hz, hi_src = _band(device, req)
    humans, human_src = _humans(device, req)
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
    lo, hi = req.human_mass_range
    base = humans[0]
    dense = [base.model_copy(update={"mass": float(m)}) for m in np.geomspace(lo, hi, _RANGE_CHECK_MASSES)]
    loop = _Loop(device, dense, req.filter_order)
    kcr, _, who, _ = loop.exact(2 * math.pi * design.filter_cutoff_hz * device.sample_time)
    if kcr < design.critical_force_gain * (1 - 1e-9):
        return dense[who]
    return None


def _design(device: Device, req: InertiaRequirements, humans: list[Human], human_src: str,
            lo_hz: float, hi_hz: float, hi_src: str) -> InertiaDesign:
    t_of = 2 * math.pi * device.sample_time
    loop = _Loop(device, humans, req.filter_order)
    rho = 10 ** (req.min_gain_margin_db / 20)
    log_rho, m = math.log(rho), device.mass
    cutoffs = np.geomspace(lo_hz, hi_hz, max(2, req.pareto_points))
    scan = [loop.exact(c * t_of) for c in cutoffs]
    kcrs = np.array([s[0] for s in scan])
    pareto = pareto_points(cutoffs, kcrs, rho, m)
    objective = "target_apparent_mass" if req.target_apparent_mass is not None else "min_apparent_mass"
    common = dict(objective=objective, filter_order=req.filter_order, cutoff_band_hz=(lo_hz, hi_hz),
                  cutoff_max_source=hi_src, pareto=pareto, humans=tuple(humans), human_source=human_src)
    info: dict = {"name": "ipopt (CasADi), exchange method, exact re-check"}

    def answer(status: str, kf: float, cutoff_hz: float, reason: str | None = None) -> InertiaDesign:
        kcr, th, who, _ = loop.exact(cutoff_hz * t_of)
        return InertiaDesign(status=status, force_gain=kf, filter_cutoff_hz=cutoff_hz, apparent_mass=m / (1 + kf),
                             critical_force_gain=kcr, gain_margin_db=20 * math.log10(kcr / kf) if kf > 0 else None,
                             crossover_frequency=None if th is None else th / device.sample_time,
                             worst_human=humans[who], rigid_model=_rigid(device, humans, req, cutoff_hz, kcr, rho),
                             solver=info, reason=reason, **common)

    if not np.all(np.isfinite(kcrs)):
        return InertiaDesign(status="infeasible", force_gain=None, filter_cutoff_hz=None, apparent_mass=None,
                             critical_force_gain=None, gain_margin_db=None, crossover_frequency=None,
                             worst_human=None, rigid_model=None, solver=info,
                             reason="no phase crossover at some cutoff: the model bounds no force gain there", **common)
    modal = []
    for plant in loop.plants:
        mp, err = modal_plant(plant)
        if not err <= _MODAL_RTOL:
            info["return_status"] = f"modal form of G_1 off by {err:.2g} (ill-conditioned eigenvectors of A)"
            return _failed(info, common, "the crossover model could not be built accurately")
        modal.append(mp)
    j_best = int(np.argmax(kcrs))
    t = cutoffs * t_of

    if objective == "min_apparent_mass":
        # The NLP tracks crossover branches; it may only move where the branches are the
        # same as at its start (a pair of crossovers can merge and vanish, making K_f,cr
        # jump: no local condition describes that, so the bracket stops there).
        lo_j, hi_j = max(j_best - 1, 0), min(j_best + 1, len(t) - 1)
        here = loop.structure(t[j_best])
        if loop.structure(t[lo_j]) != here:
            lo_j = j_best
            info["crossover_structure_changes_hz"] = [float(cutoffs[j_best - 1]), float(cutoffs[j_best])]
        if loop.structure(t[hi_j]) != here:
            hi_j = j_best
            info["crossover_structure_changes_hz"] = [float(cutoffs[j_best]), float(cutoffs[j_best + 1])]
        theta = t[j_best]
        if lo_j < hi_j:
            theta = _refine(loop, modal, log_rho, t[j_best], (t[lo_j], t[hi_j]), "max_gain", 0.0, info)
            if theta is None:
                return _failed(info, common, "Ipopt did not converge on the crossover conditions")
        else:
            info.update(return_status="scan point kept: crossover branches change on both sides", exchange_rounds=0)
        if loop.exact(theta)[0] < kcrs[j_best]:       # never worse than the exact scan's best point
            theta = t[j_best]
        return answer("optimal", loop.exact(theta)[0] / rho, theta / t_of)

    kf = m / req.target_apparent_mass - 1.0
    if kf <= 0.0:
        return InertiaDesign(status="infeasible", force_gain=0.0, filter_cutoff_hz=None, apparent_mass=m,
                             critical_force_gain=None, gain_margin_db=None, crossover_frequency=None,
                             worst_human=None, rigid_model=None, solver=info,
                             reason=f"target_apparent_mass {req.target_apparent_mass:g} is not below the device's "
                                    f"mass {m:g}: force feedforward only lowers the apparent mass", **common)
    feasible = np.nonzero(kcrs >= rho * kf)[0]
    if feasible.size == 0:
        best = kcrs[j_best] / rho
        return answer("infeasible", best, cutoffs[j_best],
                      f"K_f = {kf:.6g} (apparent mass {req.target_apparent_mass:g}) needs K_f,cr ≥ {rho * kf:.6g} "
                      f"for {req.min_gain_margin_db:g} dB, but the largest K_f,cr in [{lo_hz:g}, {hi_hz:g}] Hz is "
                      f"{kcrs[j_best]:.6g} at {cutoffs[j_best]:.4g} Hz; the best reachable with the margin is "
                      f"K_f = {best:.6g}, apparent mass {m / (1 + best):.6g}")
    j_hi = int(feasible[-1])
    if j_hi == len(t) - 1:
        info.update(return_status="upper cutoff bound feasible (exact)", exchange_rounds=0)
        return answer("optimal", kf, hi_hz)
    feasible_at = lambda th: loop.exact(th)[0] >= rho * kf  # noqa: E731
    if loop.structure(t[j_hi]) != loop.structure(t[j_hi + 1]):
        # A crossover branch is born or dies in the bracket: the boundary may be a jump of
        # K_f,cr, which no crossover condition describes; bisect the exact verdict instead.
        theta = _bisect(feasible_at, t[j_hi], t[j_hi + 1])
        info.update(return_status="exact bisection (crossover branches change in the bracket)", exchange_rounds=0)
        return answer("optimal", kf, theta / t_of)
    theta = _refine(loop, modal, log_rho, t[j_hi], (t[j_hi], t[j_hi + 1]), "max_cutoff", math.log(kf), info)
    if theta is None:
        return _failed(info, common, "Ipopt did not converge on the crossover conditions")
    theta = _exact_boundary(lambda th: math.log(loop.exact(th)[0] / (rho * kf)), t[j_hi], theta, info)
    return answer("optimal", kf, theta / t_of)


def _bisect(feasible_at, good: float, bad: float) -> float:
    """The last feasible θ before ``bad`` to a few ulp (the exact verdict decides each step)."""
    while bad - good > 8 * np.finfo(float).eps * bad:
        mid = 0.5 * (good + bad)
        if feasible_at(mid):
            good = mid
        else:
            bad = mid
    return good


def _exact_boundary(margin, feasible: float, theta: float, info: dict) -> float:
    """θ itself when the exact margin holds there; else the exact boundary between the
    last feasible scan point and θ (Brent on the exact log-margin), on its feasible side."""
    if margin(theta) >= 0.0:
        return theta
    root = brentq(margin, feasible, theta, xtol=1e-15, rtol=4 * np.finfo(float).eps)
    for _ in range(60):
        if margin(root) >= 0.0:
            break
        root = feasible + (root - feasible) * (1 - 1e-12)
    info["polished"] = "exact bracketing (Brent) of the margin boundary"
    return root


def _failed(info: dict, common: dict, reason: str) -> InertiaDesign:
    return InertiaDesign(status="failed", force_gain=None, filter_cutoff_hz=None, apparent_mass=None,
                         critical_force_gain=None, gain_margin_db=None, crossover_frequency=None,
                         worst_human=None, rigid_model=None, solver=info, reason=reason, **common)


def _rigid(device: Device, humans: list[Human], req: InertiaRequirements, cutoff_hz: float,
           kcr: float, rho: float) -> RigidComparison | None:
    if device.cable is None:
        return None
    rigid = _Loop(device.rigid(), humans, req.filter_order)
    k_r = rigid.exact(2 * math.pi * cutoff_hz * device.sample_time)[0]
    optimism = k_r / kcr - 1.0
    return RigidComparison(critical_force_gain=k_r, force_gain=k_r / rho, optimism=optimism,
                           optimistic=optimism > RIGID_OPTIMISM_FLAG)
