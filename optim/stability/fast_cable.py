"""K_cr(B) of a cable device by a bounded scan (issue 20): the scan's detection, only the binding crossover solved.

The fallback of the cable brackets (optim.stability.cable_brackets, no scan), taken where their bounds do not
close (an undamped cable, a pole or zero on the unit circle, pieces unresolved); ``path`` says which ran.

Notation of optim.stability.margins: H(θ) = −1/G_n(e^{jθ}) + β(e^{−jθ} − 1); a K > 0 crossover is a root of
Im H with Re H > 0, and there K = Re H = |H|.  The scan (optim.stability.crossovers) brackets every sign change
of Im H on its refined grid and solves every bracket to 4 ulp by Illinois steps (≈ 30 numpy passes, most of
its time).  This path keeps the scan's grid, refinement and brackets unchanged (the same crossovers are found:
nothing is lost in detection) and skips solving the brackets that cannot hold the minimum K, by a bound:

* On the arc θ ∈ [a, b] the modal form of G_n (models.discretize.StateSpaceZOH.modal_form, w = z − 1,
  y_i = (r0_i + z⁻¹r1_i)/(w − λ_i), x₁ = (g0₁ + z⁻¹g1₁ + Σ y_i e_i)/w, G_n = (c₁x₁ + Σ y_i c_i)·z^{−d}) gives by
  the triangle inequality |G_n| ≤ U = |c₁|(|g0₁| + |g1₁| + Σ Y_i|e_i|)/(2 sin(a/2)) + Σ Y_i|c_i|, with
  Y_i = (|r0_i| + |r1_i|)/min_{[a,b]}|w − λ_i| (the nearest point of the arc to 1 + λ_i, in closed form).
* So any root in [a, b] has K = |H| ≥ 1/U − 2β sin(b/2) (padded by 1e-6 relative for the modal form's own
  rounding, ≤ cond(V)·ε ≤ 1e-12).

The bracket of the lowest bound is solved first, then at once every other one whose bound is below the K found,
by the scan's own solver (Illinois to 4 ulp, elementwise: the same root as the full scan); K is Re H there by
the scan's own formula.  (A Newton solver on Im H converged in ~4 steps but moved K by up to 4e-12 where K is
ill-conditioned in θ, so the scan's solver is kept.)  The scan's near-tangency search, exact zeros on samples and Nyquist point
are kept as they are.  ``path = "bounded-scan"``; where the modal form is missing (ill-conditioned V) the
caller runs the full scan.  The crossover list is the full scan's, computed on first use only.
"""

from __future__ import annotations

import math

import numpy as np

from optim.stability.crossovers import refine_grid, solve_brackets, tangential_pairs

__all__ = ["bounded_min_crossing", "modal_bound"]

_PAD = 1e-6


def _arc_min_dist(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """min over θ ∈ [a, b] of |e^{jθ} − c| (rows: intervals; columns: points c); |e^{jθ} − c| is unimodal in θ."""
    psi = np.angle(c)
    best = np.minimum(np.abs(np.exp(1j * a) - c), np.abs(np.exp(1j * b) - c))
    for shift in (-2.0 * math.pi, 0.0, 2.0 * math.pi):
        t = np.clip(psi + shift, a, b)
        best = np.minimum(best, np.abs(np.exp(1j * t) - c))
    return best


def modal_bound(modal, beta: float, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """A lower bound on K = |H| at any crossover in [a, b] (0 < a ≤ b ≤ π), elementwise (module docstring)."""
    lam, c1, c2v, e12v, r0, r1, g0_1, g1_1 = modal
    a2, b2 = a[:, None], b[:, None]
    dist = _arc_min_dist(a2, b2, (1.0 + lam)[None, :])
    # the rounding of 1 + λ: the distance is known to ~ε absolute; shrink it by that much
    dist = np.maximum(dist - 4e-16, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        y = (np.abs(r0) + np.abs(r1))[None, :] / dist
        w = 2.0 * np.sin(0.5 * a)
        u = (abs(c1) * (abs(g0_1) + abs(g1_1) + y @ np.abs(e12v)) / w + y @ np.abs(c2v)) * (1.0 + _PAD)
        lb = 1.0 / u - 2.0 * beta * np.sin(0.5 * b)
    return np.where(np.isfinite(lb) & (lb > 0.0), lb, 0.0)


def bounded_min_crossing(h, modal, d: int, beta: float, grid: np.ndarray, damper: bool = False
                         ) -> tuple[float, float] | None:
    """(θ, α) of the K > 0 crossover with the smallest α on the scan's refined ``grid`` (the scan's
    positive_real_crossings, every candidate included, but only the brackets the bound cannot exclude solved);
    None when there is no K > 0 crossover.  ``damper``: h is the damper-only loop −1/G_n/(1 − e^{−jθ}) (β = 0),
    whose modulus is |1/G_n|/(2 sin(θ/2)) ≥ the bound over 2 sin(b/2); the answer is then (θ_b, β_max)."""
    grid, values = refine_grid(h, grid)
    im, re = values.imag, values.real
    cands: list[tuple[float, float]] = [(c.angle, c.value) for c in tangential_pairs(h, grid, values)]
    for i in np.nonzero(im[1:-1] == 0.0)[0] + 1:
        if re[i] > 0:
            cands.append((float(grid[i]), float(re[i])))
    v_pi = complex(h(np.array([math.pi]))[0])
    nyquist = v_pi.real > 0
    idx = np.nonzero((np.sign(im[:-1]) * np.sign(im[1:]) < 0) & ((re[:-1] > 0) | (re[1:] > 0)))[0]
    if nyquist:
        idx = idx[math.pi - grid[idx] > 1e-9]          # the scan drops these for the Nyquist point
        cands.append((math.pi, v_pi.real))
    if idx.size:
        lb = modal_bound(modal, beta, grid[idx], grid[idx + 1])
        if damper:
            lb = lb / (2.0 * np.sin(0.5 * grid[idx + 1]))
        order = np.argsort(lb, kind="stable")
        idx, lb = idx[order], lb[order]
        best = min((v for _, v in cands), default=math.inf)
        # the bracket of the lowest bound first, then at once every other one whose bound is below the best K
        for first in (True, False):
            sel = idx[:1] if first else idx[1:][lb[1:] < best]
            if sel.size == 0 or not lb[0] < best:
                continue
            # the scan's own solver on the scan's brackets: the same root, to the bit, as the full scan
            roots = solve_brackets(lambda t: h(t).imag, grid[sel], grid[sel + 1], im[sel], im[sel + 1])
            vals = h(roots).real
            for t, v in zip(roots, vals):
                if v > 0 and not (nyquist and math.pi - t <= 1e-9):
                    cands.append((float(t), float(v)))
                    best = min(best, float(v))
    if not cands:
        return None
    return min(cands, key=lambda c: (c[1], c[0]))

