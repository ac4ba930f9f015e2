"""The worst wall normal of a 3-DOF-range pose with B = 0 by duality: one 1-D problem in θ instead of a sphere search.

At a pose every normal n shares the modes; on the unit circle z = e^{jθ} the wall's plant along n is
g_n(θ) = nᵀ H(θ) n with H(θ) = Σ_i R_i(θ) w_i w_iᵀ = A(θ) + j C(θ) (A, C real symmetric 3 × 3, w_i = J v_i, R_i the
modes' exact ZOH responses with the delay).  With B = 0 the loop crosses at θ with K = −1/(T² g_n) exactly when
nᵀ C n = 0, and K > 0 when nᵀ A n < 0, so the lowest K over every normal crossing at θ is 1/(T² d(θ)) with

    d(θ) = max{ −nᵀ A n : nᵀ C n = 0, |n| = 1 } = min over μ of λ_max(−A + μ C)

(the equality is the S-lemma for two quadratic forms in R³: their joint numerical range on the sphere is convex,
Brickman 1961).  λ_max(−A + μC) is convex in μ, so d(θ) is a bisection on its derivative vᵀCv over a bracket set by C's
extreme eigenvalues; θ = π (C = 0) gives λ_max(−A).  The worst K over the pose is 1/(T² max_θ d(θ)): d on the exact scan's
grid, golden sections in θ around its best local maxima, and the normal from the eigenvectors at (θ*, μ*).

Certified, never trusted alone: optim.workspace.normal_search.worst_normal takes this normal only when the exact
scan's K_cr there (optim.workspace.wall_plant) equals 1/(T² d*) to 1e-9 relative; otherwise it runs the sphere
search (tests/optim/workspace/test_worst_normal.py holds both to a dense sampling of the sphere).
"""

from __future__ import annotations

import math

import numpy as np

from optim.stability.compiled import kernel

from .normal_kernel import AT_D, circle_point, mode_response

__all__ = ["dual_worst", "normal_at", "compile_kernels"]

_GOLD = 0.3819660112501051
_MU_STEPS = 80       # golden steps in μ (0.618^80 ≈ 2e-17 of the bracket), or bisection steps for μ* (2^-80)
_THETA_STEPS = 60    # golden steps in θ between the grid's neighbours of a local maximum
_CANDIDATES = 4      # local maxima of d on the grid refined
_NEAR_DOUBLE = 1.0 - 1e-6   # |r| of the closed form above this: two eigenvalues nearly meet (deflate)
_SEMI = 1e-12        # C's small extreme eigenvalue below this fraction of the other extreme: the birth limit


@kernel
def _hmat(w, modes, theta, out):
    """out[0:6] = A(θ), out[6:12] = C(θ) as (00, 01, 02, 11, 12, 22): H = Σ R_i w_i w_iᵀ, R_i as the compiled
    kernel's (RigidZOH.response, the Nyquist value in closed form)."""
    z, zm1, zinv, lead = circle_point(theta, modes[0, AT_D])
    for k in range(12):
        out[k] = 0.0
    for i in range(modes.shape[0]):
        v = modes[i]
        r = mode_response(v, theta, z, zm1, zinv, lead)
        x, y, zz = w[0, i], w[1, i], w[2, i]
        outer = (x * x, x * y, x * zz, y * y, y * zz, zz * zz)
        for k in range(6):
            out[k] += r.real * outer[k]
            out[6 + k] += r.imag * outer[k]


@kernel
def _eigvec(c0, c1, c2, c3, c4, c5, lam):
    """The unit eigenvector of the symmetric (c…) for its simple eigenvalue ``lam``: the largest cross product of
    two rows of C − λI."""
    r0 = (c0 - lam, c1, c2)
    r1 = (c1, c3 - lam, c4)
    r2 = (c2, c4, c5 - lam)
    best, vx, vy, vz = -1.0, 0.0, 0.0, 0.0
    for p, q in ((r0, r1), (r0, r2), (r1, r2)):
        x = p[1] * q[2] - p[2] * q[1]
        y = p[2] * q[0] - p[0] * q[2]
        z = p[0] * q[1] - p[1] * q[0]
        nn = x * x + y * y + z * z
        if nn > best:
            best, vx, vy, vz = nn, x, y, z
    if not best > 0.0:
        return 1.0, 0.0, 0.0
    s = math.sqrt(best)
    return vx / s, vy / s, vz / s


@kernel
def _lmax(a00, a01, a02, a11, a12, a22):
    """The largest eigenvalue of a real symmetric 3 × 3 (the trigonometric closed form; a deflation where two
    eigenvalues nearly meet)."""
    p1 = a01 * a01 + a02 * a02 + a12 * a12
    q = (a00 + a11 + a22) / 3.0
    b00, b11, b22 = a00 - q, a11 - q, a22 - q
    p2 = b00 * b00 + b11 * b11 + b22 * b22 + 2.0 * p1
    if p2 == 0.0:
        return q
    p = math.sqrt(p2 / 6.0)
    det = (b00 * (b11 * b22 - a12 * a12) - a01 * (a01 * b22 - a12 * a02) + a02 * (a01 * a12 - b11 * a02))
    r = det / (2.0 * p * p * p)
    if r <= -1.0:
        phi = math.pi / 3.0
    elif r >= 1.0:
        phi = 0.0
    else:
        phi = math.acos(r) / 3.0
    if r > -_NEAR_DOUBLE:
        return q + 2.0 * p * math.cos(phi)
    # the top two eigenvalues nearly meet (r → −1, φ → π/3): acos loses ~√ε of the angle and cos(φ) passes it on
    # (λ_max to ~1e-8; where the bottom two meet, r → 1, cos is flat at φ = 0 and λ_max stays exact).  The isolated
    # λ_min (cos is flat at φ + 2π/3 = π) and its eigenvector are well conditioned: deflate to the 2 × 2 on its
    # orthogonal complement, whose eigenvalues the stable formula gives to ~ε‖A‖ (an error δ of the eigenvector
    # moves them by O(δ²)).
    iso = q + 2.0 * p * math.cos(phi + 2.0 * math.pi / 3.0)
    vx, vy, vz = _eigvec(a00, a01, a02, a11, a12, a22, iso)
    # an orthonormal basis (e, f) of v's complement: e ⊥ v from the smallest component, f = v × e
    if abs(vx) <= abs(vy) and abs(vx) <= abs(vz):
        ex, ey, ez = 0.0, vz, -vy
    elif abs(vy) <= abs(vz):
        ex, ey, ez = -vz, 0.0, vx
    else:
        ex, ey, ez = vy, -vx, 0.0
    en = math.sqrt(ex * ex + ey * ey + ez * ez)
    ex, ey, ez = ex / en, ey / en, ez / en
    fx, fy, fz = vy * ez - vz * ey, vz * ex - vx * ez, vx * ey - vy * ex
    aex = a00 * ex + a01 * ey + a02 * ez
    aey = a01 * ex + a11 * ey + a12 * ez
    aez = a02 * ex + a12 * ey + a22 * ez
    afx = a00 * fx + a01 * fy + a02 * fz
    afy = a01 * fx + a11 * fy + a12 * fz
    afz = a02 * fx + a12 * fy + a22 * fz
    bee = ex * aex + ey * aey + ez * aez
    bff = fx * afx + fy * afy + fz * afz
    bef = ex * afx + ey * afy + ez * afz
    return 0.5 * (bee + bff) + math.sqrt(0.25 * (bee - bff) * (bee - bff) + bef * bef)


@kernel
def _slope(a0, a1, a2, a3, a4, a5, c0, c1, c2, c3, c4, c5):
    """(λ_max of the symmetric (a…), vᵀCv of its unit top eigenvector v): the derivative in μ of λ_max(A' + μC).
    v is the largest cross product of two rows of A' − λ_max I."""
    lam = _lmax(a0, a1, a2, a3, a4, a5)
    r0 = (a0 - lam, a1, a2)
    r1 = (a1, a3 - lam, a4)
    r2 = (a2, a4, a5 - lam)
    best, vx, vy, vz = -1.0, 0.0, 0.0, 0.0
    for p, q in ((r0, r1), (r0, r2), (r1, r2)):
        x = p[1] * q[2] - p[2] * q[1]
        y = p[2] * q[0] - p[0] * q[2]
        z = p[0] * q[1] - p[1] * q[0]
        nn = x * x + y * y + z * z
        if nn > best:
            best, vx, vy, vz = nn, x, y, z
    if best <= 0.0:
        return lam, 0.0
    s = (c0 * vx * vx + c3 * vy * vy + c5 * vz * vz + 2.0 * (c1 * vx * vy + c2 * vx * vz + c4 * vy * vz)) / best
    return lam, s


@kernel
def _birth(h, cmin, cmax):
    """(True, d) where C is semidefinite to _SEMI (a crossing is born or dies at this θ: the only normal with
    nᵀCn = 0 is C's eigenvector u of the eigenvalue ≈ 0, so d = −uᵀAu); (False, 0) elsewhere.  There the dual's
    minimiser μ* runs off to ~1/λ and λ_max(−A + μC) loses every digit; the limit is exact to O(_SEMI)."""
    if cmax <= _SEMI * -cmin:
        lam = cmax
    elif -cmin <= _SEMI * cmax:
        lam = cmin
    else:
        return False, 0.0
    # only a simple eigenvalue ≈ 0 has one null vector (two modes of equal λ, e.g. two undamped joints, share their
    # crossing's birth: a 2-D null space, where −uᵀAu of one vector is not the max; the dual's own value stands
    # there, and the exact scan's certificate decides)
    mid = h[6] + h[9] + h[11] - cmax - cmin
    if abs(mid) <= 1e-6 * max(cmax, -cmin):
        return False, 0.0
    ux, uy, uz = _eigvec(h[6], h[7], h[8], h[9], h[10], h[11], lam)
    d = -(h[0] * ux * ux + h[3] * uy * uy + h[5] * uz * uz + 2.0 * (h[1] * ux * uy + h[2] * ux * uz + h[4] * uy * uz))
    return True, d


@kernel
def _dual(h, steps):
    """(d, μ*): min over μ of λ_max(−A + μC) (−inf when C is definite: no normal crosses at this θ), by bisection
    on the sign of its derivative vᵀCv (nondecreasing in μ: the function is convex)."""
    c0, c1, c2, c3, c4, c5 = h[6], h[7], h[8], h[9], h[10], h[11]
    a0, a1, a2, a3, a4, a5 = -h[0], -h[1], -h[2], -h[3], -h[4], -h[5]
    cmax = _lmax(c0, c1, c2, c3, c4, c5)
    cmin = -_lmax(-c0, -c1, -c2, -c3, -c4, -c5)
    if cmax == 0.0 and cmin == 0.0:
        return _lmax(a0, a1, a2, a3, a4, a5), 0.0
    if not (cmin < 0.0 < cmax):
        return -np.inf, 0.0
    born, d_born = _birth(h, cmin, cmax)
    if born:
        return d_born, math.nan
    span = _lmax(a0, a1, a2, a3, a4, a5) + _lmax(-a0, -a1, -a2, -a3, -a4, -a5)   # λ_max − λ_min of −A
    lo, hi = -span / -cmin, span / cmax
    best, arg = np.inf, 0.0
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        lam, s = _slope(a0 + mid * c0, a1 + mid * c1, a2 + mid * c2, a3 + mid * c3, a4 + mid * c4, a5 + mid * c5,
                        c0, c1, c2, c3, c4, c5)
        if lam < best:
            best, arg = lam, mid
        if s > 0.0:
            hi = mid
        elif s < 0.0:
            lo = mid
        else:
            break
    return best, arg


@kernel
def _dual_golden(h, steps):
    """(d, μ): min over μ of λ_max(−A + μC) by a golden section (robust values: the search in θ reads these; μ
    to ~√ε only) (−inf when C is definite: no normal crosses at this θ)."""
    c0, c1, c2, c3, c4, c5 = h[6], h[7], h[8], h[9], h[10], h[11]
    a0, a1, a2, a3, a4, a5 = -h[0], -h[1], -h[2], -h[3], -h[4], -h[5]
    cmax = _lmax(c0, c1, c2, c3, c4, c5)
    cmin = -_lmax(-c0, -c1, -c2, -c3, -c4, -c5)
    if cmax == 0.0 and cmin == 0.0:
        return _lmax(a0, a1, a2, a3, a4, a5), 0.0
    if not (cmin < 0.0 < cmax):
        return -np.inf, 0.0
    born, d_born = _birth(h, cmin, cmax)
    if born:
        return d_born, math.nan
    span = _lmax(a0, a1, a2, a3, a4, a5) + _lmax(-a0, -a1, -a2, -a3, -a4, -a5)   # λ_max − λ_min of −A
    lo, hi = -span / -cmin, span / cmax
    x1 = lo + _GOLD * (hi - lo)
    x2 = hi - _GOLD * (hi - lo)
    f1 = _lmax(a0 + x1 * c0, a1 + x1 * c1, a2 + x1 * c2, a3 + x1 * c3, a4 + x1 * c4, a5 + x1 * c5)
    f2 = _lmax(a0 + x2 * c0, a1 + x2 * c1, a2 + x2 * c2, a3 + x2 * c3, a4 + x2 * c4, a5 + x2 * c5)
    for _ in range(steps):
        if f1 <= f2:
            hi, x2, f2 = x2, x1, f1
            x1 = lo + _GOLD * (hi - lo)
            f1 = _lmax(a0 + x1 * c0, a1 + x1 * c1, a2 + x1 * c2, a3 + x1 * c3, a4 + x1 * c4, a5 + x1 * c5)
        else:
            lo, x1, f1 = x1, x2, f2
            x2 = hi - _GOLD * (hi - lo)
            f2 = _lmax(a0 + x2 * c0, a1 + x2 * c1, a2 + x2 * c2, a3 + x2 * c3, a4 + x2 * c4, a5 + x2 * c5)
    return (f1, x1) if f1 <= f2 else (f2, x2)


@kernel
def _d_at(w, modes, theta, h, steps):
    _hmat(w, modes, theta, h)
    return _dual_golden(h, steps)


@kernel
def dual_worst(w, modes, grid, grid_steps):
    """(d*, θ*, μ*, A(θ*) and C(θ*) as 12 numbers): the largest d(θ) over [grid[0], π], from d on ``grid`` (``grid_steps``
    bisection steps in μ) and golden sections in θ around its best local maxima; d* ≤ 0 when no
    positive crossing exists."""
    g = grid.shape[0]
    h = np.empty(12)
    d = np.empty(g)
    for j in range(g):
        d[j] = _d_at(w, modes, grid[j], h, grid_steps)[0]
    order = np.argsort(-d)
    best_d, best_t, best_mu = -np.inf, grid[0], 0.0
    taken = 0
    for idx in range(g):
        j = order[idx]
        if taken >= _CANDIDATES or not d[j] > -np.inf:
            break
        if (j > 0 and d[j - 1] > d[j]) or (j < g - 1 and d[j + 1] > d[j]):
            continue                                    # not a local maximum on the grid
        taken += 1
        lo, hi = grid[max(j - 1, 0)], grid[min(j + 1, g - 1)]
        x1 = lo + _GOLD * (hi - lo)
        x2 = hi - _GOLD * (hi - lo)
        f1 = _d_at(w, modes, x1, h, _MU_STEPS)[0]
        f2 = _d_at(w, modes, x2, h, _MU_STEPS)[0]
        for _ in range(_THETA_STEPS):
            if f1 >= f2:
                hi, x2, f2 = x2, x1, f1
                x1 = lo + _GOLD * (hi - lo)
                f1 = _d_at(w, modes, x1, h, _MU_STEPS)[0]
            else:
                lo, x1, f1 = x1, x2, f2
                x2 = hi - _GOLD * (hi - lo)
                f2 = _d_at(w, modes, x2, h, _MU_STEPS)[0]
        cands = (grid[j], x1, x2)
        for t in cands:
            dv, mu = _d_at(w, modes, t, h, _MU_STEPS)
            if dv > best_d:
                best_d, best_t, best_mu = dv, t, mu
    out = np.empty(12)
    _hmat(w, modes, best_t, out)
    d_bis, mu_bis = _dual(out, _MU_STEPS)        # μ* to full precision for the normal
    if d_bis <= best_d or math.isnan(mu_bis) or math.isnan(best_mu):
        best_mu = mu_bis
    return best_d, best_t, best_mu, out


def normal_at(h: np.ndarray, mu: float) -> np.ndarray:
    """The unit normal attaining d at (A, C) = h's and μ*: in the span of −A + μ*C's top two eigenvectors, the
    n with nᵀCn = 0 of largest −nᵀAn (the top eigenvector itself at a smooth minimum over μ)."""
    idx = ((0, 1, 2), (1, 3, 4), (2, 4, 5))
    a = np.array([[h[k] for k in row] for row in idx])
    c = np.array([[h[6 + k] for k in row] for row in idx])
    if math.isnan(mu):          # the birth limit (_birth): C's eigenvector of its eigenvalue ≈ 0
        ev = np.linalg.eigvalsh(c)
        lam = ev[2] if abs(ev[2]) <= abs(ev[0]) else ev[0]
        return np.array(_eigvec(h[6], h[7], h[8], h[9], h[10], h[11], float(lam)))
    _, vec = np.linalg.eigh(-a + mu * c)
    v1, v2 = vec[:, 2], vec[:, 1]
    if not np.any(c):
        return v1
    c11, c12, c22 = v1 @ c @ v1, v1 @ c @ v2, v2 @ c @ v2
    # n = cos(a)·v1 + sin(a)·v2: c11 cos² + 2 c12 sin cos + c22 sin² = 0, in t = tan(a) (or a = π/2)
    cands = []
    if c22 != 0.0:
        disc = c12 * c12 - c11 * c22
        if disc >= 0.0:
            for t in ((-c12 + math.sqrt(disc)) / c22, (-c12 - math.sqrt(disc)) / c22):
                cands.append(v1 + t * v2)
    elif c12 != 0.0:
        cands.append(v1 - c11 / (2.0 * c12) * v2)
    if abs(c22) <= 1e-300 or abs(c11) <= 1e-300:
        cands.append(v2 if abs(c22) <= 1e-300 else v1)
    if not cands:
        return v1
    cands = [x / np.linalg.norm(x) for x in cands]
    n = max(cands, key=lambda x: float(-(x @ a @ x)))
    return _kkt_polish(a, c, n, mu)


def _kkt_polish(a: np.ndarray, c: np.ndarray, n: np.ndarray, mu: float, steps: int = 6) -> np.ndarray:
    """Newton on the KKT system of max −nᵀAn s.t. nᵀCn = 0, nᵀn = 1: (−A + μC)n = νn, from (n, μ); the polished
    n is kept only where it satisfies both constraints better and does not lower −nᵀAn beyond rounding."""
    x = np.concatenate([n, [mu, float(n @ (-a + mu * c) @ n)]])
    eye = np.eye(3)
    for _ in range(steps):
        v, m, nu = x[:3], x[3], x[4]
        res = np.concatenate([(-a + m * c) @ v - nu * v, [v @ c @ v, v @ v - 1.0]])
        jac = np.zeros((5, 5))
        jac[:3, :3] = -a + m * c - nu * eye
        jac[:3, 3] = c @ v
        jac[:3, 4] = -v
        jac[3, :3] = 2.0 * (c @ v)
        jac[4, :3] = 2.0 * v
        try:
            x = x - np.linalg.solve(jac, res)
        except np.linalg.LinAlgError:
            return n
        if not np.all(np.isfinite(x)):
            return n
    out = x[:3] / np.linalg.norm(x[:3])
    scale = float(np.max(np.abs(c))) or 1.0
    if abs(out @ c @ out) <= max(abs(n @ c @ n), 1e-14 * scale) and -(out @ a @ out) >= -(n @ a @ n) * (1 - 1e-14):
        return out
    return n


def compile_kernels() -> None:
    """Compile (or load from numba's cache) on a made-up pose: the first worst-normal analysis then runs at speed."""
    from models.discretize import RigidZOH

    from .normal_kernel import mode_numbers

    plants = [RigidZOH(1e-3, 0, 0.0), RigidZOH(2e-3, 1, 0.5), RigidZOH(3e-3, 1, 0.5)]
    w = np.array([[1.0, 0.2, 0.1], [0.3, 1.0, 0.2], [0.1, 0.4, 1.0]])
    dual_worst(w, mode_numbers(plants), np.linspace(0.01, math.pi, 16), 4)
