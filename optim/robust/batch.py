"""Exact K_cr(B) of many devices at once: the analysis of optim.stability.margins, vectorised across devices.

Same mathematics as optim.stability.margins.critical_stiffness (every phase crossover of
H(θ) = −1/G_n(e^{jθ}) + β(e^{−jθ} − 1) bracketed and refined to full double
precision, the Nyquist point counted, K_cr = 0 at or above B_max), but every
device of a batch is scanned at once in numpy arrays, because the worst-case
search and the verification of a robust design need thousands of devices and
numpy's per-call overhead dominates one device at a time (FIELD-NOTES.md).

How it stays exact:
* each device gets its own grid, built like optim.stability.crossovers.scan_grid (a log part
  from far below the lowest crossover, a linear part fine enough for the delay's
  phase, dense clusters at its resonances and anti-resonances), all rows of equal
  length so the batch is one 2-D array;
* every grid interval where arg H turns by more than a quarter radian is bisected
  (recursively, in flat arrays) so consecutive samples cannot hide a crossing;
* a near-tangent pair of crossings between two samples (a fold of the boundary) is
  found by minimising the signed arg over each interval where |arg H| dips below 0.05;
* each bracket is refined by the vectorised Illinois solver of optim.stability.crossovers.

Damped cable devices (with a modal form) are not scanned here: they take optim.stability.cable_batch (issue 32: the
compiled cable brackets over every row at once, B_max included; margins' own answer, to the bit, and margins itself
for the rows the brackets do not answer alone).  Measured (issue
20, loaded machine, 24 random damped cables, half at B > 0): delays up to 200 samples 53–73 → 13–16 ms a device;
up to 20 samples 6–8 → 10 ms (the batched scan shares numpy's overhead across devices there; with B swept on
one device the cable's B_max is found once: 6 cables × 8 B up to 20 samples, 6.8 → 2.0 ms a point).

It is checked against optim.stability.margins.critical_stiffness device by device
(tests/optim/robust/test_batch.py).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from models.device import Device
from models.discretize import RigidZOH, StateSpaceZOH
from models.plants import stiffness_loop_plant
from optim.errors import InputError
from optim.golden import golden_minimum
from optim.stability.cable_batch import cable_critical_stiffness_batch
from optim.stability.crossovers import (
    CLUSTER_GEOM,
    CLUSTER_HALF_WIDTH,
    CLUSTER_POINTS,
    LIN_STEP,
    LOG_END,
    LOG_MIN_SAMPLES,
    LOG_PER_DECADE,
    STEPS_PER_DELAY_TURN,
    solve_brackets,
)
from optim.stability.crossovers import theta_min as scan_theta_min
from optim.stability.fast_batch import fast_rigid_batch
from optim.stability.undamped_cable import is_undamped_cable

__all__ = ["BatchCritical", "batch_critical_stiffness", "rigid_critical_stiffness"]

_MAX_ARG_STEP = 0.25          # as optim.stability.crossovers: largest turn of arg H between samples [rad]
_TANGENT_ARG = 0.05           # as optim.stability.crossovers: |arg H| below which a near-tangency is looked for
_MAX_SPLITS = 60
_GOLDEN_STEPS = 48            # golden-section steps: 0.618^48 ≈ 1e-10 of the interval (the dip only needs detecting)


@dataclass(frozen=True)
class BatchCritical:
    """K_cr(B) of each device of a batch (arrays, one entry per device)."""

    critical_stiffness: np.ndarray
    """K_cr [N/m]; 0 when no K > 0 is stable (B ≥ B_max, or no damping at all), inf when every K > 0 is."""
    crossover_angle: np.ndarray
    """θ = ωT [rad per sample] of the crossover that sets K_cr (nan when K_cr is 0 or inf)."""
    max_stable_damping: np.ndarray
    """B_max [N·s/m] (inf when the damper-only loop has no crossover)."""
    scanned: int = 0
    """How many devices the batched scan decided (undamped cables, and rigid ones where optim.stability.fast_batch's
    bounds did not close); the others took a fast path (damped cables: optim.stability.margins' own, per device)."""


class _Evaluator:
    """1/G_n(e^{jθ}) for rows of devices that share one plant structure (θ: (N, M) array)."""

    def __init__(self, plants: Sequence[RigidZOH | StateSpaceZOH]):
        self.rigid = isinstance(plants[0], RigidZOH)
        self.d = np.array([p.d for p in plants], float)
        if self.rigid:
            coef = np.array([p.coefficients() for p in plants])      # (1−p, Φ12, g0p, g0v, g1p, g1v, 1−f)
            self.coef = [coef[:, k] for k in range(coef.shape[1])]
            c0 = np.array([p.f0_numerator() for p in plants])        # (φ₂(δ), c(δ)) of the f = 0 form
            self.a0, self.c0 = c0[:, 0], c0[:, 1]
            self.whole = np.array([p.f == 0.0 for p in plants])
            return
        modal = [p.modal_form() for p in plants]
        self.modal_ok = np.array([m is not None for m in modal])
        ref = next((m for m in modal if m is not None), None)
        if ref is not None:
            filled = [m if m is not None else tuple(np.zeros_like(np.asarray(v)) for v in ref) for m in modal]
            self.lam, self.c1, self.c2v, self.e12v, self.r0, self.r1, self.g01, self.g11 = (
                np.array([np.asarray(m[k]) for m in filled]) for k in range(8))
        mats = [p.accurate_matrices() for p in plants]
        self.emat = np.array([m[1] for m in mats])
        self.g0 = np.array([m[2] for m in mats])
        self.g1 = np.array([m[3] for m in mats])
        self.c = np.array([p.c for p in plants], float)

    def inverse(self, theta: np.ndarray, rows: np.ndarray | None = None) -> np.ndarray:
        """1/G_n at θ; ``rows`` gives the device of each θ (default: θ is (N, M) and row i is device i)."""
        if rows is None:
            shape = theta.shape
            rows = np.repeat(np.arange(shape[0]), shape[1])
            return self._inverse_flat(theta.ravel(), rows).reshape(shape)
        return self._inverse_flat(theta, rows)

    def _inverse_flat(self, theta: np.ndarray, rows: np.ndarray) -> np.ndarray:
        z = np.exp(1j * theta)
        zm1 = np.expm1(1j * theta)
        zinv = 1.0 / z
        delay = np.exp(1j * self.d[rows] * theta)
        if self.rigid:
            omp, phi12, g0p, g0v, g1p, g1v, _ = (c[rows] for c in self.coef)
            frac = (g0p + g1p * zinv) * (zm1 + omp) + phi12 * (g0v + g1v * zinv)
            num = np.where(self.whole[rows], self.a0[rows] * (z + 1.0) + self.c0[rows], frac)
            return zm1 * (zm1 + omp) * delay / num
        return delay / self._response(zm1, zinv, rows)

    def _response(self, zm1, zinv, rows) -> np.ndarray:
        """G_n without the delay: StateSpaceZOH.response's modal form where it is well conditioned, else a solve."""
        out = np.empty(zm1.shape, complex)
        ok = self.modal_ok[rows]
        if ok.any():
            r, zm, zi = rows[ok], zm1[ok], zinv[ok]
            y = (self.r0[r] + zi[:, None] * self.r1[r]) / (zm[:, None] - self.lam[r])      # V⁻¹x₂
            x1 = (self.g01[r] + zi * self.g11[r] + np.einsum("pk,pk->p", y, self.e12v[r])) / zm
            out[ok] = self.c1[r] * x1 + np.einsum("pk,pk->p", y, self.c2v[r])
        if (~ok).any():
            r, zm, zi = rows[~ok], zm1[~ok], zinv[~ok]
            n = self.emat.shape[1]
            mats = zm[:, None, None] * np.eye(n) - self.emat[r]
            rhs = self.g0[r] + zi[:, None] * self.g1[r]
            x = np.linalg.solve(mats, rhs[..., None])[..., 0]
            out[~ok] = np.einsum("pk,pk->p", x, self.c[r])
        return out


def _unit_steps(counts: np.ndarray) -> np.ndarray:
    """Row i: linspace(0, 1, counts[i]) padded with 1.0 to the longest row."""
    j = np.arange(int(counts.max()), dtype=float)[None, :]
    den = np.maximum(counts - 1, 1).astype(float)[:, None]
    return np.minimum(j / den, 1.0)


def _grids(devices: Sequence[Device], plants, betas: np.ndarray) -> np.ndarray:
    """One sorted grid per device (rows of equal length), as optim.stability.crossovers.scan_grid builds it."""
    delta = np.array([d.delta for d in devices])
    ds = np.array([d.delay_samples for d in devices])
    # θ_min of optim.stability.margins with β = 0 (the damper-only loop's scan, the lower of the two)
    theta_min = scan_theta_min(np.maximum(delta, 0.0), ds)
    theta_lin = np.maximum(LOG_END, theta_min * 10)       # as scan_grid (its constants)
    step = np.minimum(LIN_STEP, math.pi / (STEPS_PER_DELAY_TURN * (ds + 1.0)))
    # Each row's own sample counts (as scan_grid), padded to the batch's longest by repeating the row's last
    # sample: a row's distinct samples, and so its answer, do not depend on which other rows share the batch
    # (a study resumed in other chunks gives bit-identical rows).
    n_log = np.maximum(LOG_MIN_SAMPLES, (LOG_PER_DECADE * np.log10(theta_lin / theta_min)).astype(np.int64) + 2)
    n_lin = np.ceil((math.pi - theta_lin) / step).astype(np.int64) + 1
    log_part = theta_min[:, None] * (theta_lin / theta_min)[:, None] ** _unit_steps(n_log)
    lin_part = theta_lin[:, None] + (math.pi - theta_lin)[:, None] * _unit_steps(n_lin)
    parts = [log_part, lin_part]
    # a conjugate pair gives the same angle twice: one cluster is enough
    hints = [tuple(sorted({h for h in tuple(p.pole_angles()) + tuple(p.zero_angles()) if 0.0 < h <= math.pi}))
             for p in plants]
    n_h = max((len(h) for h in hints), default=0)
    if n_h:
        # rows with fewer resonances repeat their last one (or π/2): equal lengths, duplicates are harmless
        hm = np.array([list(h) + [h[-1] if h else math.pi / 2] * (n_h - len(h)) for h in hints])
        w = np.maximum(delta, 1e-6)[:, None] * CLUSTER_HALF_WIDTH
        lo, hi = np.maximum(theta_min[:, None], hm - w), np.minimum(math.pi, hm + w)
        lin = np.linspace(0.0, 1.0, CLUSTER_POINTS)
        parts.append((lo[..., None] + (hi - lo)[..., None] * lin).reshape(len(devices), -1))
        g = np.geomspace(*CLUSTER_GEOM)
        parts.append((hm[..., None] * (1.0 + g)).reshape(len(devices), -1))
        parts.append((hm[..., None] * (1.0 - g)).reshape(len(devices), -1))
    grid = np.concatenate(parts, axis=1)
    grid = np.clip(grid, theta_min[:, None], math.pi)
    grid.sort(axis=1)
    return grid


class _Loop:
    """H(θ) of one loop of a batch: K loop (−1/G_n + β(e^{−jθ} − 1)) or damper loop (−1/G_n / (1 − e^{−jθ}))."""

    def __init__(self, ev: _Evaluator, betas: np.ndarray | None):
        self.ev, self.betas = ev, betas

    def __call__(self, theta: np.ndarray, rows: np.ndarray | None = None) -> np.ndarray:
        inv = self.ev.inverse(theta, rows)
        e = np.expm1(-1j * theta)
        if self.betas is None:
            return -inv / (-e)
        b = self.betas[:, None] if rows is None else self.betas[rows]
        return -inv + b * e


def _split_turning(h: _Loop, rows, lo, hi, vlo, vhi):
    """Bisect intervals where arg H turns by more than _MAX_ARG_STEP; return the final leaves (flat arrays)."""
    leaves = []
    for _ in range(_MAX_SPLITS):
        if rows.size == 0:
            break
        turn = np.abs(np.angle(vhi / vlo))
        bad = (turn > _MAX_ARG_STEP) & ((hi - lo) > 1e-14 * hi)
        leaves.append((rows[~bad], lo[~bad], hi[~bad], vlo[~bad], vhi[~bad]))
        rows, lo, hi, vlo, vhi = rows[bad], lo[bad], hi[bad], vlo[bad], vhi[bad]
        if rows.size == 0:
            break
        mid = 0.5 * (lo + hi)
        vmid = h(mid, rows)
        rows = np.concatenate([rows, rows])
        lo, hi = np.concatenate([lo, mid]), np.concatenate([mid, hi])
        vlo, vhi = np.concatenate([vlo, vmid]), np.concatenate([vmid, vhi])
    leaves.append((rows, lo, hi, vlo, vhi))
    return tuple(np.concatenate([leaf[k] for leaf in leaves]) for k in range(5))


def _golden_dip(h: _Loop, r, a, b, sign):
    """min over [a, b] of sign·arg H (vectorised golden section): (argmin, min)."""
    return golden_minimum(lambda t: sign * np.angle(h(t, r)), a, b, _GOLDEN_STEPS)


def _dip_brackets(h: _Loop, r, lo, hi, vlo, vhi, sign):
    """Where sign·arg H dips below 0 inside [lo, hi] (both ends the same sign): brackets [lo, t*], [t*, hi]."""
    if r.size == 0:
        return (np.empty(0, int),) + (np.empty(0),) * 4
    tm, fm = _golden_dip(h, r, lo.copy(), hi.copy(), sign)
    dip = fm < 0
    r, tm = r[dip], tm[dip]
    vm = h(tm, r)
    return (np.concatenate([r, r]), np.concatenate([lo[dip], tm]), np.concatenate([tm, hi[dip]]),
            np.concatenate([vlo[dip], vm]), np.concatenate([vm, vhi[dip]]))


def _tangent_candidates_grid(grid, values, bad):
    """As optim.stability.crossovers.tangential_pairs on the base grid: a local minimum of |arg H| below 0.05 at sample i
    with the same sign at i − 1, i, i + 1 (intervals that were bisected are searched leaf by leaf instead)."""
    arg = np.angle(values)
    mag = np.abs(arg)
    c = ((mag[:, 1:-1] <= mag[:, :-2]) & (mag[:, 1:-1] <= mag[:, 2:]) & (mag[:, 1:-1] < _TANGENT_ARG)
         & (values.real[:, 1:-1] > 0) & (np.sign(arg[:, :-2]) == np.sign(arg[:, 2:]))
         & (np.sign(arg[:, 1:-1]) == np.sign(arg[:, 2:])) & (arg[:, 1:-1] != 0) & ~bad[:, :-1] & ~bad[:, 1:])
    r, i = np.nonzero(c)
    i = i + 1
    return r, grid[r, i - 1], grid[r, i + 1], values[r, i - 1], values[r, i + 1], np.sign(arg[r, i])


def _tangent_candidates_leaves(r, lo, hi, vlo, vhi):
    """Leaves of a bisected interval with |arg H| < 0.05 at an end and the same sign at both ends."""
    alo, ahi = np.angle(vlo), np.angle(vhi)
    c = ((np.minimum(np.abs(alo), np.abs(ahi)) < _TANGENT_ARG) & (np.sign(alo) == np.sign(ahi)) & (alo != 0)
         & ((vlo.real > 0) | (vhi.real > 0)))
    return r[c], lo[c], hi[c], vlo[c], vhi[c], np.sign(alo[c])


def _min_crossing(h: _Loop, grid: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(smallest positive real value of H, its angle) per row; inf/nan where there is none."""
    n = grid.shape[0]
    bad = (np.abs(np.angle(values[:, 1:] / values[:, :-1])) > _MAX_ARG_STEP) \
        & ((grid[:, 1:] - grid[:, :-1]) > 1e-14 * grid[:, 1:])
    br_, bi_ = np.nonzero(bad)
    leaves = _split_turning(h, br_, grid[br_, bi_], grid[br_, bi_ + 1], values[br_, bi_], values[br_, bi_ + 1])
    gr, gi = np.nonzero(~bad)
    r = np.concatenate([gr, leaves[0]])
    lo = np.concatenate([grid[gr, gi], leaves[1]])
    hi = np.concatenate([grid[gr, gi + 1], leaves[2]])
    vlo = np.concatenate([values[gr, gi], leaves[3]])
    vhi = np.concatenate([values[gr, gi + 1], leaves[4]])
    sign_change = (np.sign(vlo.imag) * np.sign(vhi.imag) < 0) & ((vlo.real > 0) | (vhi.real > 0))
    cands = [_tangent_candidates_grid(grid, values, bad), _tangent_candidates_leaves(*leaves)]
    tr, ta, tb, tva, tvb, ts = (np.concatenate([c[k] for c in cands]) for k in range(6))
    tr, ta, tb, tva, tvb = _dip_brackets(h, tr.astype(int), ta, tb, tva, tvb, ts)
    br = np.concatenate([r[sign_change], tr])
    a, b = np.concatenate([lo[sign_change], ta]), np.concatenate([hi[sign_change], tb])
    fa, fb = np.concatenate([vlo[sign_change].imag, tva.imag]), np.concatenate([vhi[sign_change].imag, tvb.imag])
    best = np.full(n, np.inf)
    angle = np.full(n, np.nan)
    # an exact zero of Im H on a sample (each sample is the left end of one interval; π is handled below)
    exact = (vlo.imag == 0.0) & (vlo.real > 0)
    cand_r, cand_t, cand_v = [r[exact]], [lo[exact]], [vlo[exact].real]
    if br.size:
        roots = solve_brackets(lambda t: h(t, br).imag, a, b, fa, fb)
        cand_r.append(br)
        cand_t.append(roots)
        cand_v.append(h(roots, br).real)
    cr, ct, cv = (np.concatenate(x) for x in (cand_r, cand_t, cand_v))
    v_pi = h(np.full((n, 1), math.pi)).real[:, 0]
    nyq = v_pi > 0
    # as optim.stability.crossovers: with a Nyquist crossover, a rounding-level crossing just below π is the same one
    keep = (cv > 0) & ~(nyq[cr] & (math.pi - ct <= 1e-9))
    cr, ct, cv = cr[keep], ct[keep], cv[keep]
    order = np.lexsort((cv, cr))
    cr, ct, cv = cr[order], ct[order], cv[order]
    first = np.ones(cr.size, bool)
    first[1:] = cr[1:] != cr[:-1]
    best[cr[first]] = cv[first]
    angle[cr[first]] = ct[first]
    use_pi = nyq & (v_pi < best)
    best[use_pi] = v_pi[use_pi]
    angle[use_pi] = math.pi
    return best, angle


def batch_critical_stiffness(devices: Sequence[Device], damping: float | np.ndarray) -> BatchCritical:
    """Exact K_cr [N/m] of every device at virtual damping B [N·s/m] (one B for all, or one per device).

    Devices may mix rigid and cable models.  Rigid devices take the fast exact path of optim.stability.fast_batch
    (no scan); the rows its bounds leave open, and each other structure, are scanned as one batch.
    """
    n = len(devices)
    bvec = np.broadcast_to(np.asarray(damping, float), (n,)).copy()
    if not np.all(np.isfinite(bvec) & (bvec >= 0)):
        raise InputError("damping", "virtual damping B must be finite and ≥ 0")
    kcr, ang, bmax = np.full(n, np.inf), np.full(n, np.nan), np.full(n, np.inf)
    rigid = [i for i, d in enumerate(devices) if d.cable is None]
    rest = [i for i, d in enumerate(devices) if d.cable is not None]
    if rigid:
        rest += _fast_rigid_rows([devices[i] for i in rigid], bvec, np.array(rigid), kcr, ang, bmax)
    plants = {i: stiffness_loop_plant(devices[i]) for i in rest}
    cables = [i for i in rest if _damped_cable(devices[i], plants[i])]
    if cables:
        _cable_rows([devices[i] for i in cables], bvec, np.array(cables), kcr, ang, bmax)
        rest = [i for i in rest if i not in set(cables)]
    groups: dict[tuple, list[int]] = {}
    for i in sorted(rest):
        p = plants[i]
        key = ("rigid",) if isinstance(p, RigidZOH) else ("ss", p.a.shape[0])
        groups.setdefault(key, []).append(i)
    for idx in groups.values():
        sub = [devices[i] for i in idx]
        k, a, bm = _batch_one_structure(sub, [plants[i] for i in idx], bvec[idx])
        kcr[idx], ang[idx], bmax[idx] = k, a, bm
    return BatchCritical(kcr, ang, bmax, len(rest))


def rigid_critical_stiffness(mass: np.ndarray, damping: np.ndarray, sample_time: np.ndarray, delay: np.ndarray,
                             virtual_damping: np.ndarray, devices: Callable[[list[int]], Sequence[Device]]
                             ) -> BatchCritical:
    """batch_critical_stiffness of rigid devices given as arrays (m, b, T, t_d) [SI], without a Device per row:
    the same numbers, bit for bit (the same fast path, and the rows it leaves open scanned as Devices made by
    ``devices(rows)``).  The arrays must hold valid devices and B ≥ 0 (the caller validated them)."""
    n = len(mass)
    bvec = np.asarray(virtual_damping, float)
    kcr, ang, bmax = np.full(n, np.inf), np.full(n, np.nan), np.full(n, np.inf)
    rest = _fast_rigid_arrays(np.asarray(mass, float), np.asarray(damping, float), np.asarray(sample_time, float),
                              np.asarray(delay, float), bvec, np.arange(n), kcr, ang, bmax)
    if rest:
        sub = batch_critical_stiffness(devices(rest), bvec[rest])
        kcr[rest], ang[rest], bmax[rest] = sub.critical_stiffness, sub.crossover_angle, sub.max_stable_damping
    return BatchCritical(kcr, ang, bmax, len(rest))


def _damped_cable(device: Device, plant) -> bool:
    """A cable with some damping and a modal form: optim.stability.margins answers it without a full scan."""
    return (device.cable is not None and isinstance(plant, StateSpaceZOH) and not is_undamped_cable(device)
            and plant.modal_form() is not None)


def _cable_rows(devices, bvec, idx, kcr, ang, bmax) -> None:
    """Damped cables (results written in place) by optim.stability.cable_batch (issue 32): every row's B_max and
    K_cr(B) by the compiled cable brackets in one call, the rows they do not answer alone by optim.stability.margins
    device by device (the bounded scan, the 40-digit re-solve near B_max).  margins' own answers, to the bit: a row
    depends on its own device alone."""
    res = cable_critical_stiffness_batch(devices, bvec[idx])
    kcr[idx] = res.critical_stiffness
    ang[idx] = res.crossover_angle
    bmax[idx] = res.max_stable_damping


def _fast_rigid_rows(devices, bvec, idx, kcr, ang, bmax) -> list[int]:
    """optim.stability.fast_batch on the rigid rows idx (results written in place); returns the rows it leaves to the scan."""
    m, b_phys, t, td = np.array([(d.mass, d.damping, d.sample_time, d.delay) for d in devices]).T
    return _fast_rigid_arrays(m, b_phys, t, td, bvec, idx, kcr, ang, bmax)


def _fast_rigid_arrays(m, b_phys, t, td, bvec, idx, kcr, ang, bmax) -> list[int]:
    ks, bs = m / t**2, m / t                  # Device.stiffness_scale, damping_scale
    b = bvec[idx]
    res = fast_rigid_batch(b_phys * t / m, td / t, b / bs)
    ok = res.ok
    rows = idx[ok]
    bm = res.beta_max[ok] * bs[ok]
    dead = (b_phys[ok] + b[ok] <= 0.0) | ((b[ok] > 0.0) & (b[ok] >= bm))
    kcr[rows] = np.where(dead, 0.0, res.alpha[ok] * ks[ok])
    ang[rows] = np.where(dead, np.nan, res.theta[ok])
    bmax[rows] = bm
    return [int(i) for i in idx[~ok]]


def _batch_one_structure(devices, plants, damping: np.ndarray):
    ks = np.array([d.stiffness_scale for d in devices])
    bs = np.array([d.damping_scale for d in devices])
    phys = np.array([d.damping for d in devices])
    betas = damping / bs
    ev = _Evaluator(plants)
    grid = _grids(devices, plants, betas)
    inv = ev.inverse(grid)
    e = np.expm1(-1j * grid)
    k_loop, d_loop = _Loop(ev, betas), _Loop(ev, None)
    alpha, angle = _min_crossing(k_loop, grid, -inv + betas[:, None] * e)
    beta_max, _ = _min_crossing(d_loop, grid, -inv / (-e))
    kcr = alpha * ks
    bmax = beta_max * bs
    dead = (phys + damping <= 0.0) | ((damping > 0.0) & (damping >= bmax))
    kcr = np.where(dead, 0.0, kcr)
    angle = np.where(dead | ~np.isfinite(kcr), np.nan, angle)
    return kcr, angle, bmax
