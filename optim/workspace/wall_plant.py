"""The wall's SISO plant of a multi-DOF device at one pose and normal, and its exact critical stiffness.

G_n(s) = nᵀ J (M s² + D s)⁻¹ Jᵀ n.  With the generalised eigenvectors of (D, M) (VᵀMV = I, VᵀDV = Λ) this is a sum
of rigid modes, G_n(s) = Σ c_i / (s (s + λ_i)) with c_i = (nᵀ J v_i)² [1/kg] and λ_i ≥ 0 [1/s]: every pole is real
(the arm has no stiffness once gravity is compensated).  Each mode is the chapter's rigid plant 1/(m_i s² + b_i s)
with m_i = 1/c_i, b_i = λ_i/c_i, so its exact ZOH with any delay is models.discretize.RigidZOH, and by linearity the
sampled G_n(z) is their sum: exact, no Padé.  K_cr is the smallest K > 0 of every crossover of
K(θ) = −1/G_n(e^{jθ}) − B(1 − e^{−jθ})/T, found by the same adaptive scan as the 1-DOF cable loop
(optim.stability.crossovers.positive_real_crossings).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from models.discretize import RigidZOH, split_delay
from models.errors import InputError
from optim.stability.crossovers import positive_real_crossings, scan_grid, theta_min
from optim.stability.fast_rigid import fast_rigid
from optim.stability.margins import NO_DAMPING_REASON

from .normal_kernel import mode_numbers
from .wall_kernel import KIND_DAMPER, KIND_STIFFNESS, plain_scan_grid, wall_crossings

__all__ = ["WallModes", "wall_modes", "pose_eig", "check_mode_rates", "undamped_unstable", "UNDAMPED_REASON",
           "MIN_MODE_RATE", "one_dof_critical_stiffness", "WallCritical", "wall_critical_stiffness", "one_dof_equivalent",
           "max_stable_damping"]

#: A mode whose weight c_i is below this fraction of Σ c_i is not seen along n (rounding of the projection).
_UNSEEN = 1e-14


@dataclass(frozen=True)
class WallModes:
    """The modes of G_n: weights ``c`` [1/kg] and decay rates ``lam`` [1/s] (the modes seen along n only)."""

    c: tuple[float, ...]
    lam: tuple[float, ...]

    @property
    def effective_mass(self) -> float:
        """1/(nᵀ J M⁻¹ Jᵀ n) [kg]: the mass the wall feels at high frequency."""
        return 1.0 / math.fsum(self.c)

    @property
    def effective_damping(self) -> float:
        """m_e²·Σ c_i λ_i = m_e²·nᵀ J M⁻¹ D M⁻¹ Jᵀ n [N·s/m]: the damping of the 1-DOF plant 1/(m_e s² + b_e s)
        that matches G_n's expansion in 1/s to second order (the 1-DOF approximation)."""
        m = self.effective_mass
        return m * m * math.fsum(ci * li for ci, li in zip(self.c, self.lam))


def pose_eig(mass: np.ndarray, damping: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(Λ, V) of (D, M): DV = MVΛ, VᵀMV = I (every normal at the pose shares them).

    Undamped joints (D_jj = 0 exactly) give exact zero eigenvalues, first: their modes span {v : Dv = 0} (the
    vectors on those joints, M-orthonormalised by M_ZZ's Cholesky factor); the damped modes live in its M-orthogonal
    complement, v = (x, −M_ZZ⁻¹M_ZP x), where vᵀMv = xᵀSx (S = M_PP − M_PZ M_ZZ⁻¹ M_ZP, the Schur complement) and
    vᵀDv = xᵀD_P x: eigh(D_P, S) has every eigenvalue > 0.  (eigh of the full pair returns ±1e-17-sized values for
    them, which a mode's c_i/λ_i turns into a damping the joint does not have.)"""
    damping = np.asarray(damping, dtype=float)
    zero = damping == 0.0
    if not zero.any():
        return scipy.linalg.eigh(np.diag(damping), mass)
    n = len(damping)
    zi, pi = np.flatnonzero(zero), np.flatnonzero(~zero)
    m_zz, m_zp, m_pp = mass[np.ix_(zi, zi)], mass[np.ix_(zi, pi)], mass[np.ix_(pi, pi)]
    chol = np.linalg.cholesky(m_zz)                                        # M_ZZ = L Lᵀ
    vec = np.zeros((n, n))
    vec[zi, :len(zi)] = np.linalg.inv(chol).T                              # (L⁻ᵀ)ᵀ M_ZZ L⁻ᵀ = I
    lam = np.zeros(n)
    if len(pi):
        back = np.linalg.solve(m_zz, m_zp)                                 # M_ZZ⁻¹ M_ZP
        schur = m_pp - m_zp.T @ back
        schur = 0.5 * (schur + schur.T)
        lam_p, x = scipy.linalg.eigh(np.diag(damping[pi]), schur)
        vec[pi, len(zi):] = x
        vec[zi, len(zi):] = -back @ x
        lam[len(zi):] = lam_p
    return lam, vec


def wall_modes(mass: np.ndarray, jac: np.ndarray, damping: np.ndarray, normal: np.ndarray,
               eig: tuple[np.ndarray, np.ndarray] | None = None) -> WallModes:
    """The modes of nᵀ J (M s² + D s)⁻¹ Jᵀ n (M symmetric positive definite, D diagonal ≥ 0); ``eig`` is
    pose_eig(mass, damping) when the caller has it."""
    lam, vec = pose_eig(mass, damping) if eig is None else eig     # DV = MVΛ, VᵀMV = I
    proj = (normal @ jac) @ vec
    c = proj * proj
    total = float(np.sum(c))
    keep = c > _UNSEEN * total
    return WallModes(tuple(float(x) for x in c[keep]), tuple(max(float(x), 0.0) for x in lam[keep]))


#: Joint damping so small that a damped mode's λ·T is below this (but not 0) is refused: its K_cr ~ λ·m/T would
#: be a number no double-precision scan resolves (give 0 for an undamped joint).
MIN_MODE_RATE = 1e-9

UNDAMPED_REASON = ("the wall sees an undamped mode (a joint without damping) and too little damping beside it: "
                   "with B = 0 every positive stiffness is unstable (a < τ·c₀: the undamped modes' weight c₀ times "
                   "the loop's delay τ = t_d + T/2 exceeds a = Σ c_i/λ_i of the damped ones); give the wall a "
                   "virtual damping B or the joints damping")


def check_mode_rates(lam: np.ndarray, sample_time: float) -> None:
    """InputError on ``device.kinematics.joint_damping`` when a mode's 0 < λ·T < MIN_MODE_RATE."""
    tiny = (lam > 0.0) & (lam * sample_time < MIN_MODE_RATE)
    if np.any(tiny):
        raise InputError("device.kinematics.joint_damping",
                         f"damping so small that a mode decays at λ·T = {float(np.max(lam[tiny] * sample_time)):.3g}"
                         f" < {MIN_MODE_RATE:g} per sample (not resolvable in double precision): give 0 for an "
                         "undamped joint, or a damping with λ·T ≥ 1e-9")


def undamped_unstable(modes: WallModes, sample_time: float, delay: float) -> bool:
    """B = 0 and an undamped mode seen along n: K_cr = 0 when a ≤ τ·c₀ (c₀ = Σ c_i of the undamped modes,
    a = Σ c_i/λ_i of the damped ones, τ = t_d + T/2).  Small K puts the loop's poles at s ≈ ±j√(K c₀) with real part
    −K(a − τ c₀)/2: G_n e^{−sτ} = (c₀ + (a − τ c₀)s + O(s²))/s² (the ZOH is e^{−sT/2}(1 + O(s²)) on 1/s²)."""
    c0, a = undamped_weights(modes)
    if c0 == 0.0:
        return False
    return a <= (delay + 0.5 * sample_time) * c0


def undamped_weights(modes: WallModes) -> tuple[float, float]:
    """(c₀, a): the undamped modes' weight Σ c_i (λ_i = 0) and the damped ones' Σ c_i/λ_i (λ_i > 0)."""
    c0 = math.fsum(ci for ci, li in zip(modes.c, modes.lam) if li == 0.0)
    a = math.fsum(ci / li for ci, li in zip(modes.c, modes.lam) if li > 0.0)
    return c0, a


@dataclass(frozen=True)
class WallCritical:
    """K_cr [N/m] of the wall along n, its crossover frequency [rad/s] (None when none binds), every crossover
    (frequency [rad/s], K [N/m]) and why when K_cr is 0 or infinite."""

    critical_stiffness: float
    frequency: float | None
    crossovers: tuple[tuple[float, float], ...]
    reason: str | None = None


def _grid(modes: WallModes, sample_time: float, delay_samples: float, beta: float, compiled: bool = False
          ) -> np.ndarray:
    m = modes.effective_mass
    deltas = [li * sample_time for li in modes.lam]
    # the lowest damping any piece of the loop can have, normalised by m_e: every mode's own δ_i, and the
    # low-frequency damping 1/Σ(c_i/λ_i) (zero when an undamped mode is seen)
    low = 0.0 if any(li == 0.0 for li in modes.lam) else \
        sample_time / (m * math.fsum(ci / li for ci, li in zip(modes.c, modes.lam)))
    if low == 0.0 and beta == 0.0:
        # an undamped mode seen and a > τ·c₀ (undamped_unstable is False): the lowest crossover is at θ ~ √r with
        # r = a/(τ c₀) − 1 the margin of the small-K rule; the scan starts below it
        c0, a = undamped_weights(modes)
        tau = (delay_samples + 0.5) * sample_time
        low = min(max(a / (tau * c0) - 1.0, 0.0), 1.0)
    damp = min([low] + deltas) + beta
    if compiled:
        return plain_scan_grid(theta_min(float(damp), float(delay_samples)), float(delay_samples))
    return scan_grid(theta_min(float(damp), float(delay_samples)), delay_samples, (),
                     width_hint=max(min(deltas), 1e-6))


def _max_stable_damping(plants, modes: WallModes, sample_time: float, d_samples: float, compiled: bool = True
                        ) -> float:
    """B_max [N·s/m]: the smallest positive crossover gain of the damper-only loop B(1 − z⁻¹)/T·G_n."""
    def h(theta: np.ndarray) -> np.ndarray:
        g = sum(w * p.response(theta) for w, p in plants)
        return (-1.0 / g) / (-np.expm1(-1j * theta))

    grid = _grid(modes, sample_time, d_samples, 0.0, compiled)
    values: list[float] | np.ndarray
    if compiled:
        _, values, ok = wall_crossings(np.array([w for w, _ in plants]), mode_numbers([p for _, p in plants]), grid,
                                       0.0, KIND_DAMPER)
        if not ok:
            values = [c.value for c in positive_real_crossings(h, grid)]
    else:
        values = [c.value for c in positive_real_crossings(h, grid)]
    if not len(values):
        return math.inf
    return float(min(values)) * modes.effective_mass / sample_time


def max_stable_damping(modes: WallModes, sample_time: float, delay: float) -> float:
    """B_max [N·s/m] of the wall along n: past it no K > 0 is stable (inf when the damper-only loop never crosses)."""
    d_samples = delay / sample_time
    d, f = split_delay(d_samples)
    m = modes.effective_mass
    plants = [(ci * m, RigidZOH(li * sample_time, d, f)) for ci, li in zip(modes.c, modes.lam)]
    return _max_stable_damping(plants, modes, sample_time, d_samples)


def wall_critical_stiffness(modes: WallModes, sample_time: float, delay: float, damping: float = 0.0,
                            compiled: bool = True) -> WallCritical:
    """The exact K_cr of the sampled wall loop on G_n with ZOH and ``delay`` [s], virtual damping B [N·s/m].

    The scan is compiled (optim.workspace.wall_kernel); ``compiled=False`` runs its Python twin (the oracle)."""
    if damping == 0.0 and all(li == 0.0 for li in modes.lam):
        return WallCritical(0.0, None, (), NO_DAMPING_REASON)
    if damping == 0.0 and undamped_unstable(modes, sample_time, delay):
        return WallCritical(0.0, None, (), UNDAMPED_REASON)
    d_samples = delay / sample_time
    d, f = split_delay(d_samples)
    m = modes.effective_mass
    plants = [(ci * m, RigidZOH(li * sample_time, d, f)) for ci, li in zip(modes.c, modes.lam)]
    beta = damping * sample_time / m

    def h(theta: np.ndarray) -> np.ndarray:
        g = sum(w * p.response(theta) for w, p in plants)
        return -1.0 / g + beta * np.expm1(-1j * theta)

    if damping > 0.0:
        b_max = _max_stable_damping(plants, modes, sample_time, d_samples, compiled)
        if damping >= b_max:
            return WallCritical(0.0, None, (), f"virtual damping B = {damping:.6g} N·s/m is at or above B_max = "
                                               f"{b_max:.6g} N·s/m (the damper-only loop's critical gain): no "
                                               "positive stiffness is stable")
    grid = _grid(modes, sample_time, d_samples, beta, compiled)
    scale = m / sample_time ** 2
    pairs: list[tuple[float, float]] | None = None
    if compiled:
        angles, values, ok = wall_crossings(np.array([w for w, _ in plants]), mode_numbers([p for _, p in plants]),
                                            grid, beta, KIND_STIFFNESS)
        if ok:
            pairs = list(zip(angles.tolist(), values.tolist()))
    if pairs is None:
        pairs = [(c.angle, c.value) for c in positive_real_crossings(h, grid)]
    crossovers = tuple((a / sample_time, v * scale) for a, v in pairs)
    if not crossovers:
        return WallCritical(math.inf, None, (), "no phase crossover: every positive stiffness is stable")
    best = min(crossovers, key=lambda c: c[1])
    return WallCritical(best[1], best[0], crossovers)


def one_dof_equivalent(modes: WallModes) -> WallModes:
    """The 1-DOF approximation 1/(m_e s² + b_e s) as a one-mode WallModes."""
    m, b = modes.effective_mass, modes.effective_damping
    return WallModes((1.0 / m,), (b / m,))


def one_dof_critical_stiffness(modes: WallModes, sample_time: float, delay: float, damping: float = 0.0) -> float:
    """K_cr [N/m] of the 1-DOF approximation (one_dof_equivalent(modes)): at B = 0 by the rigid fast path
    (optim.stability.fast_rigid: the product's own exact rigid K_cr, µs), elsewhere or where it does not close by
    the wall scan (tests/optim/workspace/test_wall_kernel.py holds the two to 1e-12)."""
    one = one_dof_equivalent(modes)
    if damping == 0.0 and one.lam[0] > 0.0:
        d, f = split_delay(delay / sample_time)
        res = fast_rigid(RigidZOH(one.lam[0] * sample_time, d, f), 0.0)
        if res is not None and res.theta is not None:
            return res.alpha * one.effective_mass / sample_time ** 2
    return wall_critical_stiffness(one, sample_time, delay, damping).critical_stiffness
