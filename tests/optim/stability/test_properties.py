"""Invariances and monotonicity of K_cr (hypothesis)."""

from __future__ import annotations

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from models.device import Device
from optim.stability.margins import critical_stiffness, linear_estimate

_SETTINGS = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])

deltas = st.floats(1e-6, 0.05)
betas = st.floats(0.0, 0.05)
delays = st.floats(0.0, 8.0)
scales = st.floats(0.01, 100.0)


def _alpha(delta, beta, d, m=1.0, t=1e-3):
    dev = Device(mass=m, damping=delta * m / t, sample_time=t, delay=d * t)
    return critical_stiffness(dev, beta * m / t).critical_stiffness * t * t / m


@_SETTINGS
@given(deltas, betas, delays, scales, scales)
def test_table1_scaling_invariance(delta, beta, d, s_m, s_t):
    """Scaling m and T while keeping δ, β, d fixed leaves α_cr = K_cr T²/m unchanged (chapter Table 1)."""
    a1 = _alpha(delta, beta, d)
    a2 = _alpha(delta, beta, d, m=s_m, t=1e-3 * s_t)
    assert abs(a2 / a1 - 1) <= 1e-9


@_SETTINGS
@given(deltas, delays, st.floats(1.01, 3.0))
def test_more_physical_damping_allows_more_stiffness(delta, d, factor):
    assert _alpha(delta * factor, 0.0, d) > _alpha(delta, 0.0, d)


@_SETTINGS
@given(deltas, betas, delays, st.floats(0.05, 3.0))
def test_more_delay_allows_less_stiffness(delta, beta, d, extra):
    a0, a1 = _alpha(delta, beta, d), _alpha(delta, beta, d + extra)
    if a0 > 0:
        assert a1 < a0


@_SETTINGS
@given(st.floats(1e-7, 1e-3), st.floats(0.0, 1e-3), delays)
def test_linear_estimate_error_is_order_one_plus_d_times_damping(delta, beta, d):
    """|eq. 10 / K_cr − 1| = O((1+d)(δ+β)); on small damping the constant stays below 2."""
    t, m = 1e-3, 1.0
    dev = Device(mass=m, damping=delta * m / t, sample_time=t, delay=d * t)
    b = beta * m / t
    k = critical_stiffness(dev, b).critical_stiffness
    assert abs(linear_estimate(dev, b) / k - 1) <= 2 * (1 + d) * (delta + beta)
