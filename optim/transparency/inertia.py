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
from dataclasses import dataclass, field

import numpy as np
from models.device import Device, Human
from models.feedforward import feedforward_plant
from models.filters import MAX_FILTER_ORDER

from optim.transparency.feedforward import critical_force_gain_of_plant, resolve_human
from optim.transparency.inertia_band import band_profile, highest_feasible, maximise
from optim.transparency.inertia_nlp import modal_plant
from optim.errors import InputError

__all__ = ["InertiaRequirements", "ParetoPoint", "RigidComparison", "InertiaDesign", "design_inertia",
           "upper_cutoff_hz", "pareto_points", "RIGID_OPTIMISM_FLAG"]

#: Flag the rigid model when its critical K_f exceeds the cable model's by more than this.
RIGID_OPTIMISM_FLAG = 0.20
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
    kcrs = np.array([loop.exact(c * t_of)[0] for c in cutoffs])
    pareto = pareto_points(cutoffs, kcrs, rho, m)
    objective = "target_apparent_mass" if req.target_apparent_mass is not None else "min_apparent_mass"
    common = dict(objective=objective, filter_order=req.filter_order, cutoff_band_hz=(lo_hz, hi_hz),
                  cutoff_max_source=hi_src, pareto=pareto, humans=tuple(humans), human_source=human_src)
    info: dict = {"name": "ipopt (CasADi), exchange method, exact re-check"}

    t_lo, t_hi = cutoffs[0] * t_of, cutoffs[-1] * t_of

    def answer(status: str, kf: float, theta: float, reason: str | None = None) -> InertiaDesign:
        # at θ itself: a cutoff next to a jump of K_f,cr must not round across it
        kcr, th, who, _ = loop.exact(theta)
        cutoff_hz = {t_lo: lo_hz, t_hi: hi_hz}.get(theta, theta / t_of)   # the band's edges as given
        return InertiaDesign(status=status, force_gain=kf, filter_cutoff_hz=cutoff_hz, apparent_mass=m / (1 + kf),
                             critical_force_gain=kcr, gain_margin_db=20 * math.log10(kcr / kf) if kf > 0 else None,
                             crossover_frequency=None if th is None else th / device.sample_time,
                             worst_human=humans[who], rigid_model=_rigid(device, humans, req, cutoff_hz, kcr, rho),
                             solver=info, reason=reason, **common)

    if not np.all(np.isfinite(kcrs)):
        return _no_crossover(info, common)
    modal = []
    for plant in loop.plants:
        mp, err = modal_plant(plant)
        if not err <= _MODAL_RTOL:
            info["return_status"] = f"modal form of G_1 off by {err:.2g} (ill-conditioned eigenvectors of A)"
            return _failed(info, common, "the crossover model could not be built accurately")
        modal.append(mp)
    profile = band_profile(loop, cutoffs * t_of)
    if profile.jumps:
        info["crossover_structure_changes_hz"] = [[lo / t_of, hi / t_of] for lo, hi in profile.jumps]
    if not np.all(np.isfinite(profile.kcrs)):
        return _no_crossover(info, common)

    if objective == "min_apparent_mass":
        found = maximise(loop, profile, modal, log_rho, info)
        if found.failed:
            return _failed(info, common, "Ipopt did not converge on the crossover conditions")
        return answer("optimal", loop.exact(found.theta)[0] / rho, found.theta)

    kf = m / req.target_apparent_mass - 1.0
    if kf <= 0.0:
        return InertiaDesign(status="infeasible", force_gain=0.0, filter_cutoff_hz=None, apparent_mass=m,
                             critical_force_gain=None, gain_margin_db=None, crossover_frequency=None,
                             worst_human=None, rigid_model=None, solver=info,
                             reason=f"target_apparent_mass {req.target_apparent_mass:g} is not below the device's "
                                    f"mass {m:g}: force feedforward only lowers the apparent mass", **common)
    found = highest_feasible(loop, profile, modal, log_rho, rho * kf, info)
    if found.failed:
        return _failed(info, common, "Ipopt did not converge on the crossover conditions")
    if found.theta is None:
        th_best, k_best = found.best
        best = k_best / rho
        return answer("infeasible", best, th_best,
                      f"K_f = {kf:.6g} (apparent mass {req.target_apparent_mass:g}) needs K_f,cr ≥ {rho * kf:.6g} "
                      f"for {req.min_gain_margin_db:g} dB, but the largest K_f,cr in [{lo_hz:g}, {hi_hz:g}] Hz is "
                      f"{k_best:.6g} at {th_best / t_of:.4g} Hz; the best reachable with the margin is "
                      f"K_f = {best:.6g}, apparent mass {m / (1 + best):.6g}")
    return answer("optimal", kf, found.theta)


def _no_crossover(info: dict, common: dict) -> InertiaDesign:
    return InertiaDesign(status="infeasible", force_gain=None, filter_cutoff_hz=None, apparent_mass=None,
                         critical_force_gain=None, gain_margin_db=None, crossover_frequency=None,
                         worst_human=None, rigid_model=None, solver=info,
                         reason="no phase crossover at some cutoff: the model bounds no force gain there", **common)


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
