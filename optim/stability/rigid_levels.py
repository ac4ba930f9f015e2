"""Every K > 0 crossover of a rigid loop on its rising range (issue 20).

Notation of optim.stability.fast_rigid.  On [0, θ_r] F̃ = ψ − asin(min(g, 1)) rises, so the K > 0 crossovers
there are its roots at the levels 2πk, k = 0, 1, … (F̃(θ_r) above the last one), one per level, and each lies
in [θ_{k−1}, θ_r] (θ₀ the binding crossover of fast_rigid, level 0): F̃(θ_{k−1}) = 2π(k − 1) < 2πk < F̃(θ_r).
Each level is fast_rigid's bracketed Newton in that bracket, started from the spacing of the roots below it (F̃
is (d + m + ½)θ plus bounded arguments: nearly linear, so Newton starts a few digits from the root), stopping
early where quadratic convergence shows the root within a quarter ulp and F̃' ≥ slope/2, then polished by one
secant step on Im H.  At β = 0 with a whole-sample delay, H = 2·sin(θ/2)·R·e^{jψ} exactly,
so at the root K = 2·sin(θ/2)·R(θ), a product of positive terms: taken so where K is not steep in θ (d ln K/d ln θ
≤ 6: an ulp of θ moves K by ≤ 6 ulp), else the polish (Im H pins θ where an ulp of θ is many ulps of K); against
the 30-digit reference on 473 crossovers of 40 random devices: the same median (1 ulp) and largest (4.8e-15)
error as the polished list.  The count of roots is the monotonicity argument's; no root is accepted without its
bracket.

The loop over the levels is compiled (optim.stability.rigid_kernel, held bit for bit to its Python twin,
tests/optim/stability/rigid_python.py): ≈ 0.3 µs a level, where Python took ≈ 2.5 µs and numpy passes over all
levels at once (≈ 250 array operations of ≈ 0.4 µs) did no better below a hundred levels.
"""

from __future__ import annotations

import math

from models.discretize import RigidZOH
from optim.stability.fast_rigid import RigidLoop, rigid_loop
from optim.stability.rigid_kernel import k_eq, level_roots

__all__ = ["rigid_crossovers", "level_count"]

_HALF_PI = 0.5 * math.pi
_TWO_PI = 2.0 * math.pi


def level_count(L: RigidLoop, beta: float) -> int:
    """How many levels 2πk, k ≥ 1, F̃ passes below θ_r: the K > 0 crossovers above the binding one on [0, θ_r]."""
    tr = L.theta_r
    top = (L.half_pis_at_pi - 1) * _HALF_PI if tr == math.pi else k_eq(L.numbers, beta, tr)[0]
    n = max(int(top // _TWO_PI), 0)                 # the levels 2πk < top, as the scalar loop counted them
    while _TWO_PI * (n + 1) < top:
        n += 1
    while n > 0 and not _TWO_PI * n < top:
        n -= 1
    return n


def rigid_crossovers(plant: RigidZOH, beta: float, first: tuple[float, float], tail,
                     loop: RigidLoop | None = None) -> list[tuple[float, float]] | None:
    """Every K > 0 crossover (θ, α), by frequency, for β below β_max; ``first`` is fast_rigid's (θ, α).

    On [0, θ_r] the crossovers are F̃'s roots at the levels 2πk (k = 0 is ``first``), solved in turn by the
    compiled loop (module docstring); past θ_r, where nothing is monotone, ``tail(θ_r)`` (the scan restricted to [θ_r, π], Nyquist
    included, or the Nyquist point alone where optim.stability.rigid_tail proves the rest clear) lists them.
    None where the fast path has no θ_r (the caller scans everything)."""
    L = loop if loop is not None else rigid_loop(plant)
    if L is None:
        return None
    tr = L.theta_r
    t0, a0 = first
    out = [(t0, a0)]
    if t0 < tr:
        n = level_count(L, beta)
        if n > 0:
            theta, alpha = level_roots(L.numbers, beta, n, t0, tr)
            out += zip(theta.tolist(), alpha.tolist())
    # a tail crossover already listed (within 1e-12): the tail's lie in [θ_r, π] and the roots below θ_r rise
    # with k, so the nearest root is the last one
    seen = [out[-1][0]]
    for t, a in tail(tr):
        if all(abs(t - u) > 1e-12 * t for u in seen):
            out.append((t, a))
            seen.append(t)
    out.sort()
    return [c for c in out if c[1] > 0.0]
