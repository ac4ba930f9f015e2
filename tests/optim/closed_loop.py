"""Independent check of a critical force gain: closed-loop poles of the sampled loop.

Builds the closed-loop state matrix from the plant's (Φ, Γ0, Γ1, C, D), the
filter's state space from scipy.signal.butter (not the closed form the analysis
uses) and the chain of delayed inputs, and returns its spectral radius.  A
frequency-domain K_f,cr is right when the radius crosses 1 there.
"""

from __future__ import annotations

import numpy as np

from models.feedforward import FeedforwardPlant
from models.filters import ButterworthLowPass


def closed_loop_matrix(plant: FeedforwardPlant, force_gain: float, filt: ButterworthLowPass | None) -> np.ndarray:
    """M with s[k+1] = M s[k] for u = -K_f·D·y, y[k] = C x[k] + D_dir u[k-d-1]."""
    phi, g0, g1, c = plant.matrices()
    n, d, dd = phi.shape[0], plant.d, plant.direct
    if filt is None:
        af, bf, cf, df = np.zeros((0, 0)), np.zeros(0), np.zeros(0), 1.0
    else:
        af, bf, cf, df = filt.state_space()
    nf, chain = af.shape[0], d + 1                  # chain[j] = u[k-1-j], j = 0..d
    size = n + nf + chain
    ix, iw, iu = slice(0, n), slice(n, n + nf), n + nf

    # y[k] and u[k] as rows acting on the state s = [x, w, u[k-1], ..., u[k-d-1]]
    y = np.zeros(size)
    y[ix] = c
    y[iu + d] += dd
    u = np.zeros(size)
    u[iw] = -force_gain * cf
    u += -force_gain * df * y

    m = np.zeros((size, size))
    m[ix, ix] = phi
    u_kd = u if d == 0 else np.eye(size)[iu + d - 1]   # u[k-d]
    m[ix, :] += np.outer(g0, u_kd)
    m[ix, iu + d] += g1                               # u[k-d-1]
    if nf:
        m[iw, iw] = af
        m[iw, :] += np.outer(bf, y)
    m[iu, :] = u
    for j in range(1, chain):
        m[iu + j, iu + j - 1] = 1.0
    return m


def spectral_radius(plant: FeedforwardPlant, force_gain: float, filt: ButterworthLowPass | None) -> float:
    return float(np.max(np.abs(np.linalg.eigvals(closed_loop_matrix(plant, force_gain, filt)))))
