"""Exact propagation of a linear recursion z[k+1] = A z[k] + b w[k], outputs only, without a per-sample loop.

No compiled loop is available, so the recursion is cut into blocks of L samples:
the block starts z[jL] follow z[(j+1)L] = A^L z[jL] (N/L small matrix-vector
products), and every sample inside a block is (O A^i) z[jL] for the precomputed
table O A^i, i < L: one tensor contraction.  With L ≈ √N both parts cost O(√N)
Python steps.  The forced response of the outputs is the convolution of their
impulse response (the homogeneous response from z = b, shifted by one) with w,
done by FFT.  Nothing is approximated beyond floating-point rounding.

Divergence: the block recursion stops once a block start is non-finite or beyond
1e150 in norm; the outputs after that are NaN and the caller truncates there.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import oaconvolve

__all__ = ["homogeneous_outputs", "linear_outputs", "DIVERGED_NORM"]

DIVERGED_NORM = 1e150


def homogeneous_outputs(a: np.ndarray, z0: np.ndarray, out: np.ndarray, n_samples: int) -> np.ndarray:
    """y[k] = out · A^k z0 for k = 0..n_samples-1, shape (p, n_samples); NaN after divergence."""
    n = a.shape[0]
    block = max(8, int(math.ceil(math.sqrt(n_samples))))
    n_blocks = int(math.ceil(n_samples / block))
    table = np.empty((block, out.shape[0], n))
    row = out.astype(float).copy()
    for i in range(block):
        table[i] = row
        row = row @ a
    a_block = np.linalg.matrix_power(a, block)
    starts = np.full((n, n_blocks), np.nan)
    z = np.asarray(z0, dtype=float).copy()
    for j in range(n_blocks):
        if not np.all(np.isfinite(z)) or np.abs(z).max() > DIVERGED_NORM:
            break
        starts[:, j] = z
        z = a_block @ z
    with np.errstate(invalid="ignore", over="ignore"):
        y = np.einsum("ipn,nj->pji", table, starts).reshape(out.shape[0], n_blocks * block)
    return y[:, :n_samples]


def linear_outputs(a: np.ndarray, z0: np.ndarray, out: np.ndarray, n_samples: int,
                   b: np.ndarray | None = None, w: np.ndarray | None = None,
                   d_out: np.ndarray | None = None) -> np.ndarray:
    """y[k] = out·z[k] + d_out·w[k], z[k+1] = A z[k] + b w[k], k = 0..n_samples-1."""
    y = homogeneous_outputs(a, z0, out, n_samples)
    if w is None or b is None or not np.any(w):
        return y
    w = np.asarray(w, dtype=float)[:n_samples]
    # impulse response of the outputs: h[0] = d_out, h[k] = out A^{k-1} b
    h = np.zeros((out.shape[0], n_samples))
    if n_samples > 1:
        h[:, 1:] = homogeneous_outputs(a, b, out, n_samples - 1)
    if d_out is not None:
        h[:, 0] = d_out
    finite = np.all(np.isfinite(h), axis=0)
    if not finite.all():
        stop = int(np.argmin(finite))
        h[:, stop:] = 0.0
        y[:, stop:] = np.nan
    with np.errstate(invalid="ignore", over="ignore"):
        forced = oaconvolve(h, w[None, :], axes=1)[:, :n_samples]
    return y + forced
