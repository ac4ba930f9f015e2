"""Golden-section search on many intervals at once (numpy, lock step): the batched scans' 1-D minimiser."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

__all__ = ["golden_minimum"]

_G = (math.sqrt(5.0) - 1.0) / 2.0


def golden_minimum(f: Callable[[np.ndarray], np.ndarray], a: np.ndarray, b: np.ndarray,
                   steps: int) -> tuple[np.ndarray, np.ndarray]:
    """(argmin, min) of f over each [a_i, b_i]; ``f`` maps an array of points (one per interval) to values.

    Each step keeps the part of the bracket that holds the smaller interior value and shrinks it by
    0.618 (one evaluation of f per step), so ``steps`` fixes the precision: 0.618^steps of the width."""
    a, b = np.asarray(a, float).copy(), np.asarray(b, float).copy()
    x1, x2 = b - _G * (b - a), a + _G * (b - a)
    f1, f2 = f(x1), f(x2)
    for _ in range(steps):
        left = f1 < f2                       # the minimum is in [a, x2]
        a, b = np.where(left, a, x1), np.where(left, x2, b)
        n1 = np.where(left, b - _G * (b - a), x2)
        n2 = np.where(left, x1, a + _G * (b - a))
        fn = f(np.where(left, n1, n2))
        f1, f2 = np.where(left, fn, f2), np.where(left, f1, fn)
        x1, x2 = n1, n2
    return np.where(f1 < f2, x1, x2), np.minimum(f1, f2)
