"""optim.stability.nonlinear against independent methods: the describing functions by numerical Fourier
integrals, the Abbott–Okamura limit by hand, the regimes against zwidth's exact K_cr."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from models.device import Device
from optim.stability.margins import critical_stiffness
from optim.stability.nonlinear import (
    analyse_nonlinear,
    friction_damping,
    passive_stiffness_limit,
    quantizer_gain,
)


def _fourier_gain(amplitude: float, q: float) -> float:
    """First-harmonic gain of q·round(x/q) for x = A sin θ: (4/πA)·∫_0^{π/2} q·round(A sin θ/q)·sin θ dθ by
    quadrature, piece by piece between the count thresholds (quarter-wave symmetry of an odd staircase)."""
    cuts = [0.0] + [math.asin((i - 0.5) * q / amplitude) for i in range(1, 10_000)
                    if (i - 0.5) * q < amplitude] + [math.pi / 2]
    total = sum(quad(lambda th: q * round(amplitude * math.sin(th) / q) * math.sin(th), a, b)[0]
                for a, b in zip(cuts, cuts[1:]))
    return 4 * total / (math.pi * amplitude)


@pytest.mark.parametrize("ratio", [0.3, 0.52, 0.7071, 1.0, 1.37, 2.5, 7.9, 31.0])
def test_quantizer_gain_is_the_first_harmonic(ratio):
    # the closed form against a quadrature of the staircase (rtol: quad's own accuracy on a step function)
    assert math.isclose(quantizer_gain(ratio, 1.0), _fourier_gain(ratio, 1.0), rel_tol=1e-6, abs_tol=1e-9)


def test_quantizer_gain_peaks_at_four_over_pi():
    assert math.isclose(quantizer_gain(1 / math.sqrt(2), 1.0), 4 / math.pi, rel_tol=1e-12)
    assert quantizer_gain(0.49, 1.0) == 0.0
    assert abs(quantizer_gain(1e4 + 0.3, 1.0) - 1.0) < 1e-5


def test_friction_damping_dissipates_what_coulomb_does_per_cycle():
    # energy per cycle: Coulomb 4·f_c·A, viscous b·π·A²·ω (by hand)
    f_c, a, w = 0.3, 2e-3, 50.0
    assert math.isclose(friction_damping(f_c, a, w) * math.pi * a * a * w, 4 * f_c * a, rel_tol=1e-14)


def test_abbott_okamura_limit_by_hand():
    dev = Device(mass=0.2, damping=0.5, encoder_resolution=2e-5, coulomb_friction=0.02)
    lim = passive_stiffness_limit(dev, 0.0)
    assert lim.covered and lim.binding == "sampling" and lim.stiffness == 1000.0   # min(2·0.5/1e-3, 2·0.02/2e-5)
    no_friction = Device(mass=0.2, damping=0.5, encoder_resolution=2e-5)
    assert passive_stiffness_limit(no_friction, 0.0).stiffness == 0.0   # any quantised wall without friction
    delayed = dev.model_copy(update={"delay": 0.002})
    assert not passive_stiffness_limit(delayed, 0.0).covered


@pytest.mark.parametrize("factor", [0.5, 0.9, 1.1, 2.0])
def test_regime_agrees_with_the_exact_linear_loop(factor):
    dev = Device(mass=0.2, damping=0.5, coulomb_friction=0.01, encoder_resolution=1e-5)
    kcr = critical_stiffness(dev, 0.0).critical_stiffness
    res = analyse_nonlinear(dev, factor * kcr, 0.0)
    assert (res.regime == "unstable") == (factor > 1)
    if factor > 1:   # friction holds small motions: the threshold is finite and positive
        assert res.limit_cycle.threshold_amplitude is not None and res.limit_cycle.threshold_amplitude > 0


def test_a_quantised_wall_without_friction_near_k_cr_cycles():
    # N_q peaks at 4/π: K between π/4·K_cr and K_cr must cycle by the describing function
    dev = Device(mass=0.2, damping=0.5, encoder_resolution=1e-5)
    kcr = critical_stiffness(dev, 0.0).critical_stiffness
    res = analyse_nonlinear(dev, 0.95 * kcr, 0.0)
    assert res.regime == "limit_cycle" and res.limit_cycle.exists
    assert 1e-5 / 2 < res.limit_cycle.amplitude < 1e-4
    # far below π/4·K_cr the describing function finds no cycle and the orbit search none either
    low = analyse_nonlinear(dev, 0.3 * kcr, 0.0)
    assert low.regime == "stable_not_passive" and not low.limit_cycle.exists


def test_below_the_describing_functions_reach_an_exact_orbit_is_a_cycle_the_simulation_sustains():
    # 0.6·K_cr: N_q·K < K_cr at every amplitude (no DF cycle), but the sampled three-level force pulse train has an
    # exact periodic orbit; a release from 1.5× it settles into a cycle within the stated tolerances
    from optim.nonlinear_verification import AMPLITUDE_RTOL, FREQUENCY_RTOL, measure_cycle
    dev = Device(mass=0.2, damping=0.5, encoder_resolution=1e-5)
    k = 0.6 * critical_stiffness(dev, 0.0).critical_stiffness
    res = analyse_nonlinear(dev, k, 0.0)
    c = res.limit_cycle
    assert res.regime == "limit_cycle" and c.method.startswith("exact periodic orbit")
    meas = measure_cycle(dev, k, 0.0, 1.5 * c.amplitude, 3.0)
    assert meas.state == "cycle"
    assert abs(meas.amplitude / c.amplitude - 1) <= AMPLITUDE_RTOL
    assert abs(meas.frequency_hz / c.frequency_hz - 1) <= FREQUENCY_RTOL


def test_the_velocity_filter_enters_the_limit_cycle_prediction():
    # a low-pass on the damper's velocity adds lag: K_cr(B) falls, so a wall the backward difference keeps below
    # the DF's cycle must be judged on the filtered loop (not the backward difference's)
    from models.velocity_filter import LowPass, rendering
    from optim.stability.rendered import rendered_critical_stiffness
    dev = Device(mass=0.2, damping=0.5, encoder_resolution=1e-5, coulomb_friction=0.002)
    b = 2.0
    filt = rendering(LowPass(kind="low_pass", cutoff_hz=30.0), 0.0, dev.sample_time)
    k_plain = critical_stiffness(dev, b).critical_stiffness
    k_filt = rendered_critical_stiffness(dev, b, filt).critical_stiffness
    assert k_filt < 0.9 * k_plain
    k = 0.5 * (k_filt + k_plain)        # stable with the backward difference, unstable with the filter
    assert analyse_nonlinear(dev, k, b).regime != "unstable"
    filtered = analyse_nonlinear(dev, k, b, filt)
    assert filtered.regime == "unstable"
    assert not filtered.passive.covered and "velocity filter" in filtered.passive.reason


def test_no_fields_no_block():
    assert analyse_nonlinear(Device(mass=0.2, damping=0.5), 500.0, 0.0) is None


def test_rigid_scan_is_cheap_enough():
    dev = Device(mass=0.2, damping=0.5, encoder_resolution=1e-5, coulomb_friction=0.01)
    assert np.isfinite(passive_stiffness_limit(dev, 0.0).stiffness)


def test_small_friction_over_an_exact_frictionless_orbit_is_undetermined():
    # σ = f_c/(Kq) ≈ 0.02: the DF (friction as damping) finds no cycle, the loop without friction has an exact orbit;
    # on the random walls such walls both cycled and settled (docs/quantisation_runs.md): the call is undetermined
    base = Device(mass=0.2, damping=5.0, delay=0.005, encoder_resolution=1e-6)
    k = 0.81 * critical_stiffness(base, 0.0).critical_stiffness
    bare = analyse_nonlinear(base, k, 0.0)
    assert bare.regime == "limit_cycle" and bare.limit_cycle.method.startswith("exact periodic orbit")
    small = analyse_nonlinear(base.model_copy(update={"coulomb_friction": 0.02 * k * 1e-6}), k, 0.0)
    assert small.regime == "undetermined" and "σ" in small.reason
    # friction well above the band: the DF decides (no orbit search over it)
    big = analyse_nonlinear(base.model_copy(update={"coulomb_friction": 0.3 * k * 1e-6}), k, 0.0)
    assert big.regime in ("stable_not_passive", "limit_cycle")
