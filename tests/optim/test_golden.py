"""optim.golden: the lock-step golden-section search against closed-form minima."""

import numpy as np

from optim.golden import golden_minimum


def test_parabolas_and_an_end_minimum():
    centres = np.array([0.3, -1.7, 2.0, 5.0])            # the last is outside its bracket: the minimum is its end
    a, b = np.array([0.0, -3.0, 1.0, 0.0]), np.array([1.0, 0.0, 4.0, 1.0])
    x, fx = golden_minimum(lambda t: (t - centres) ** 2 + 1.0, a, b, 80)
    np.testing.assert_allclose(x, [0.3, -1.7, 2.0, 1.0], atol=1e-8)
    np.testing.assert_allclose(fx, [1.0, 1.0, 1.0, 17.0], rtol=1e-15, atol=1e-15)


def test_cosine_minimum_to_full_precision_in_value():
    x, fx = golden_minimum(np.cos, np.array([2.0]), np.array([4.0]), 80)
    assert abs(x[0] - np.pi) < 1e-7 and fx[0] == -1.0
