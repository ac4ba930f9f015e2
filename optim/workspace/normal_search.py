"""The worst wall normal at one pose: K_cr(n) of many normals at once, then a polish.

At a pose every normal shares the modes (λ_i, v_i) of (D, M); only the weights c_i(n) = (n·w_i)², w_i = J v_i, move
with n.  So each mode's sampled response R_i(θ) is computed once on the scan's initial grid and G_n = T² Σ c_i R_i
is one matrix product for a whole set of normals.  The binding crossover of each normal is bracketed on that grid
and solved by a few vectorised secant steps on Im K(θ) (with R_i evaluated exactly at the new θ): the search's
value.  The answer's own K_cr is then the exact scan's (optim.workspace.wall_plant) at the normal found; the search
is held to a dense sampling of the sphere by tests/optim/workspace/test_worst_normal.py.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.optimize

from models.discretize import RigidZOH, split_delay
from optim.stability.crossovers import scan_grid, theta_min

from .normal_dual import dual_worst, normal_at
from .normal_kernel import critical_kernel, mode_numbers
from .wall_kernel import plain_scan_grid
from .wall_plant import pose_eig

__all__ = ["worst_normal", "dual_normal", "undamped_normal"]

_CIRCLE = 180
_SPHERE = 1200
_SECANT_STEPS = 8
_SAMPLE_STEPS = 3    # secant steps of the sphere's sampling (it ranks the starts)
_STARTS = 3          # the best samples polished
_STENCIL = 7         # a 7 × 7 stencil of (polar, azimuth) offsets per level
_ZOOM = 2.5          # the stencil shrinks by this each level (it spans ±1 step: neighbours overlap)
_STEP_MIN = 1e-11    # [rad]
_STEP_SETTLED = 1e-4  # [rad]: the zoom may stop early only below this step
_DUAL_GRID_STEPS = 40  # golden steps in μ for d(θ) on the grid (a ranking: the maxima are refined with more)


class _PoseLoop:
    """K(θ) of the wall loop at one pose, for arrays of normals."""

    def __init__(self, mass: np.ndarray, jac: np.ndarray, damping_q: np.ndarray, sample_time: float, delay: float,
                 damping: float):
        lam, vec = pose_eig(mass, damping_q)                 # undamped joints: exact zeros
        self.w = jac @ vec                                   # 3 × modes
        self.t, self.b = sample_time, damping
        d, f = split_delay(delay / sample_time)
        self.plants = [RigidZOH(max(float(li), 0.0) * sample_time, d, f) for li in lam]
        m_scale = float(np.max(np.sum(self.w * self.w, axis=0)))   # any normal's Σc_i ≤ this: a δ floor below
        deltas = [p.delta for p in self.plants]
        damp = min(deltas) * min(1.0, 1.0 / max(m_scale, 1e-300)) + damping * sample_time * 1e-3
        self.grid = scan_grid(theta_min(float(max(damp, 0.0)), float(delay / sample_time)), delay / sample_time, (),
                              width_hint=max(min(deltas), 1e-6))
        self.r_grid = np.stack([p.response(self.grid) for p in self.plants])     # modes × G
        self.modes = mode_numbers(self.plants)

    def k_of(self, g_sum: np.ndarray, theta: np.ndarray) -> np.ndarray:
        """K(θ) [N/m] from Σ c_i R_i(θ)."""
        return -1.0 / (self.t ** 2 * g_sum) - self.b * (-np.expm1(-1j * theta)) / self.t

    def _at(self, c_rows: np.ndarray, theta: np.ndarray) -> np.ndarray:
        """K at one θ per row (weights c_rows, rows × modes)."""
        r = np.stack([p.response(theta) for p in self.plants], axis=1)       # rows × modes
        return self.k_of(np.sum(c_rows * r, axis=1), theta)

    def critical(self, normals: np.ndarray, window: tuple[int, int] | None = None, steps: int = _SECANT_STEPS
                 ) -> np.ndarray:
        """The smallest positive crossover K of each normal (inf where none), from the grid and secant steps;
        ``window`` (grid indices) looks only there (the polish: the binding crossover moves little).  Compiled
        (optim.workspace.normal_kernel); ``critical_python`` is its twin."""
        c = (normals @ self.w) ** 2
        lo, hi = (0, len(self.grid)) if window is None else window
        best, col = critical_kernel(np.ascontiguousarray(c), np.ascontiguousarray(self.r_grid[:, lo:hi]),
                                    np.ascontiguousarray(self.grid[lo:hi]), self.modes, self.t, self.b, steps,
                                    hi >= len(self.grid))
        if window is None and len(normals) > 1 and col >= 0:
            self.binding = int(col) + lo
        return best

    def critical_python(self, normals: np.ndarray, window: tuple[int, int] | None = None,
                        steps: int = _SECANT_STEPS) -> np.ndarray:
        """critical's Python twin (numpy): the oracle of the compiled kernel."""
        c = (normals @ self.w) ** 2                                           # N × modes
        lo, hi = (0, len(self.grid)) if window is None else window
        grid = self.grid[lo:hi]
        k = self.k_of(c @ self.r_grid[:, lo:hi], grid)                        # N × G
        im, re = k.imag, k.real
        rows, cols = np.nonzero((np.sign(im[:, :-1]) * np.sign(im[:, 1:]) < 0) & ((re[:, :-1] > 0) | (re[:, 1:] > 0)))
        best = np.full(len(normals), math.inf)
        if rows.size:
            a, b = grid[cols], grid[cols + 1]
            fa, fb = im[rows, cols], im[rows, cols + 1]
            cr = c[rows]
            for _ in range(steps):
                x = b - fb * (b - a) / (fb - fa)
                x = np.clip(x, np.minimum(a, b), np.maximum(a, b))
                fx = self._at(cr, x).imag
                same = np.sign(fx) == np.sign(fa)
                a, fa = np.where(same, x, a), np.where(same, fx, fa)
                b, fb = np.where(same, b, x), np.where(same, fb, fx)
            x = np.where(np.abs(fa) < np.abs(fb), a, b)
            kx = self._at(cr, x).real
            kx = np.where(kx > 0, kx, math.inf)
            np.minimum.at(best, rows, kx)
            if window is None and len(normals) > 1:
                j = int(np.argmin(np.where(np.isfinite(kx), kx, np.inf)))
                self.binding = int(cols[j])
        if hi < len(self.grid):
            return best
        pi = re[:, -1]                                                        # θ = π is on the grid
        return np.minimum(best, np.where(pi > 0, pi, math.inf))

    def near_binding(self) -> tuple[int, int] | None:
        """Grid indices around the sampled normals' binding crossover (None when it was θ = π)."""
        j = getattr(self, "binding", None)
        return None if j is None else (max(j - 3, 0), min(j + 5, len(self.grid)))


def dual_normal(mass: np.ndarray, jac: np.ndarray, damping_q: np.ndarray, sample_time: float, delay: float,
                eig: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, float] | None:
    """B = 0, J of rank 3: the worst normal by duality (optim.workspace.normal_dual) and the K [N/m] it predicts
    there, 1/(T² d*); None when no positive crossing was found.  The caller certifies it by the exact scan.
    ``eig``: wall_plant.pose_eig(mass, damping_q) when the caller has it."""
    lam, vec = pose_eig(mass, damping_q) if eig is None else eig
    w = np.ascontiguousarray(jac @ vec)
    d, f = split_delay(delay / sample_time)
    plants = [RigidZOH(max(float(li), 0.0) * sample_time, d, f) for li in lam]
    m_scale = float(np.max(np.sum(w * w, axis=0)))
    deltas = [p.delta for p in plants]
    damp = min(deltas) * min(1.0, 1.0 / max(m_scale, 1e-300))
    grid = plain_scan_grid(theta_min(float(max(damp, 0.0)), float(delay / sample_time)), float(delay / sample_time))
    best, _, mu, h = dual_worst(w, mode_numbers(plants), grid, _DUAL_GRID_STEPS)
    if not (best > 0.0 and math.isfinite(best)):
        return None
    # d* is accurate where −A + μ*C's top two eigenvalues meet (normal_dual._lmax deflates there) and at a crossing's
    # birth (C semidefinite: normal_dual._birth); the exact scan at the normal still decides (the caller)
    return normal_at(h, mu), 1.0 / (sample_time ** 2 * best)


def undamped_normal(jac: np.ndarray, eig: tuple[np.ndarray, np.ndarray], sample_time: float, delay: float
                    ) -> np.ndarray | None:
    """B = 0 with undamped joints: a normal of K_cr = 0, decided exactly (no search), or None when there is none.

    Along n the undamped modes weigh c₀ = nᵀUn (U = Σ w_i w_iᵀ over λ_i = 0) and the damped ones give
    a = nᵀAn (A = Σ w_i w_iᵀ/λ_i over λ_i > 0), w_i = J v_i; K_cr = 0 where a ≤ τ·c₀, τ = t_d + T/2
    (wall_plant.undamped_unstable).  The lowest eigenvector of the quadratic form A − τU is such a normal whenever
    one exists (its eigenvalue is then ≤ 0); with three joints or fewer and J of full rank that is every pose with
    an undamped joint (A's null direction, nᵀCn = 0 for the damping form C = Σ λ_i w_i w_iᵀ, sees an undamped mode).
    The exact scan at the normal (wall_plant.wall_critical_stiffness applies the same rule) gives the answer."""
    lam, vec = eig
    zero = lam == 0.0
    if not zero.any():
        return None
    w = jac @ vec
    u = w[:, zero] @ w[:, zero].T
    a = (w[:, ~zero] / lam[~zero]) @ w[:, ~zero].T
    tau = delay + 0.5 * sample_time
    vals, vecs = np.linalg.eigh(a - tau * u)
    # clearly negative: a rounding-sized eigenvalue (a direction J does not reach, where A and U both vanish, or
    # a = τ·c₀ to 1e-12) is left to the search and the exact scan
    scale = float(np.max(np.abs(np.linalg.eigvalsh(a + tau * u))))
    if not vals[0] < -1e-12 * scale:
        return None
    n = vecs[:, 0]
    return n / np.linalg.norm(n)


def worst_normal(mass: np.ndarray, jac: np.ndarray, damping_q: np.ndarray, rank: int, sample_time: float,
                 delay: float, damping: float) -> np.ndarray:
    """The unit normal of lowest K_cr in the range of J (n and −n alike), by sampling and a bounded polish."""
    u, _, _ = np.linalg.svd(jac)
    basis = u[:, :rank]
    if rank == 1:
        return basis[:, 0]
    loop = _PoseLoop(mass, jac, damping_q, sample_time, delay, damping)
    if rank == 2:
        phis = np.linspace(0.0, math.pi, _CIRCLE, endpoint=False)

        def normals(ph: np.ndarray) -> np.ndarray:
            return (basis @ np.stack([np.cos(ph), np.sin(ph)])).T

        vals = loop.critical(normals(phis))
        i = int(np.argmin(vals))
        step = math.pi / _CIRCLE
        win = loop.near_binding()
        # a normal without a crossover in the window reads 1e30 (finite: Brent's parabolic steps stay real)
        res = scipy.optimize.minimize_scalar(lambda p: min(float(loop.critical(normals(np.array([p])), win)[0]),
                                                           1e30),
                                             bounds=(phis[i] - step, phis[i] + step), method="bounded",
                                             options={"xatol": 1e-11})
        return normals(np.array([res.x if res.fun <= vals[i] else phis[i]]))[0]

    def sphere(tp: np.ndarray) -> np.ndarray:
        t, p = tp[..., 0], tp[..., 1]
        return (basis @ np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)]).reshape(3, -1)).T

    k = np.arange(_SPHERE) + 0.5
    starts = np.stack([np.arccos(1.0 - k / _SPHERE), (math.pi * (1.0 + 5.0 ** 0.5) * k) % (2 * math.pi)], axis=1)
    vals = loop.critical(sphere(starts), steps=_SAMPLE_STEPS)   # a ranking only: each start is re-evaluated
    win = loop.near_binding()
    best = starts[np.argsort(vals)[:_STARTS]]
    best_v = np.full(len(best), math.inf)      # the first level (its stencil holds each start) sets the values
    # a zooming stencil around each of the best samples, all of them in one vectorised call per level: the
    # stencil's centre is kept, so each start's value never rises
    step = math.sqrt(4.0 * math.pi / _SPHERE)
    offsets = np.linspace(-1.0, 1.0, _STENCIL)
    grid = np.stack(np.meshgrid(offsets, offsets, indexing="ij"), axis=-1).reshape(-1, 2)
    quiet = 0
    while step > _STEP_MIN:
        before = best_v.copy()
        cand = best[:, None, :] + step * grid[None, :, :]                       # starts × stencil × 2
        v = loop.critical(sphere(cand.reshape(-1, 2)), win).reshape(len(best), -1)
        j = np.argmin(v, axis=1)
        better = v[np.arange(len(best)), j] < best_v
        best = np.where(better[:, None], cand[np.arange(len(best)), j], best)
        best_v = np.where(better, v[np.arange(len(best)), j], best_v)
        step /= _ZOOM
        # converged: below _STEP_SETTLED, two levels in a row gain less than 1e-13 relative at every start (a level's
        # gain bounds the rest's, which shrink geometrically with the step whether the minimum is smooth or a kink)
        # (a start with no crossover in the window stays at inf: inf − inf is no gain, not NaN)
        gain = np.where(np.isinf(before) & np.isinf(best_v), 0.0, before - np.where(np.isinf(before), 0.0, best_v))
        still = np.all(gain <= 1e-13 * np.abs(best_v))
        quiet = quiet + 1 if still else 0
        if step < _STEP_SETTLED and quiet >= 2:
            break
    return sphere(best[int(np.argmin(best_v))][None, :])[0]
