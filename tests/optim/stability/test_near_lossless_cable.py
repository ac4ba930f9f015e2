"""Cables whose mode lies within NEAR_LOSSLESS_GAP = 1e-12 of the unit circle, but not on it (dampings nearly 0).

The documented domain reaches δ = 1e-30; the property runs stopped at 1e-10.  Down there the crossover scan cannot
see the damper-only loop's crossing that B makes next to the mode, and it answered K_cr = 2,422 N/m (B = 14.6 N·s/m,
"B_max" 105) for the device below, where B drives the mode out through the delay: the 40-digit reference says
K_cr = 0 (55 s, not rerun here) and the closed loop is unstable at half the answer.  Such an answer is now held to
the closed loop and refused on ``device.cable`` when contradicted, as for the lossless cable
(optim.stability.undamped_cable).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from models.device import Device
from optim.errors import InputError
from optim.stability.margins import critical_stiffness, loop_plant, max_stable_damping
from optim.stability.undamped_cable import NEAR_LOSSLESS_GAP, mode_gap
from optim.verification import verify_critical_stiffness
from tests.optim.independent import spectral_radius

OUTWARDS = Device(mass=0.3718880302123106, sample_time=7.550180564703286e-05, delay=0.005511631812233399, cable=dict(
    motor_mass=0.15702801878884048, motor_damping=1.002121143167607e-18, body_mass=0.2148600114234701,
    body_damping=9.694563528812543e-19, stiffness=2225773.6892579114, damping=7.957161227232108e-27))
B = 14.579178034964086


def test_the_scan_answer_the_closed_loop_contradicts_is_refused_on_the_cable():
    assert mode_gap(loop_plant(OUTWARDS)) < NEAR_LOSSLESS_GAP
    m, t = OUTWARDS.mass, OUTWARDS.sample_time
    assert spectral_radius(OUTWARDS, 1e-6 * t * t / m, B * t / m) > 1.001     # unstable already at K = 1e-6 N/m
    with pytest.raises(InputError) as err:
        critical_stiffness(OUTWARDS, B)
    assert err.value.field == "device.cable" and "closed loop does not confirm" in err.value.rule


@pytest.mark.slow
def test_no_near_lossless_answer_is_contradicted():
    """Random cables with the mode 1e-22 … 1e-10 from the circle and δ 1e-22 … 1e-10: every answer is confirmed,
    not checkable (double precision cannot decide: verify says so), or refused — none contradicted."""
    rng = np.random.default_rng(3)
    seen = 0
    for _ in range(60):
        t, m = 10 ** rng.uniform(-4.5, -2), 10 ** rng.uniform(-1, 1.5)
        mr = m * rng.uniform(0.05, 0.5)
        md = m - mr
        wn = min(10 ** rng.uniform(1, 4), 0.9 * math.pi / t)
        kc = wn ** 2 * mr * md / m
        bc = 2 * 10 ** rng.uniform(-22, -10) / (wn * t) * math.sqrt(kc * mr * md / m)
        b0 = 10 ** rng.uniform(-22, -10) * m / t
        br = b0 * rng.uniform(0, 1)
        d = [0.0, float(rng.integers(1, 6)), rng.uniform(0, 40), rng.uniform(0, 120)][rng.integers(0, 4)]
        dev = Device(sample_time=t, delay=d * t, cable=dict(motor_mass=mr, body_mass=md, motor_damping=br,
                                                            body_damping=b0 - br, stiffness=kc, damping=bc))
        try:
            b = 0.0
            if rng.random() < 0.5:
                bm = max_stable_damping(dev)
                b = bm * rng.uniform(0, 1) if math.isfinite(bm) else 0.0
            k = critical_stiffness(dev, b).critical_stiffness
        except InputError as exc:
            assert exc.field == "device.cable", exc
            continue
        seen += 1
        assert verify_critical_stiffness(dev, b, k).verdict != "contradicted", (dev, b, k)
    assert seen >= 40


# δ ≈ 2e-14, the cable damping ≈ 4e-19, no delay: the exact rung's K_cr = 1.98086e-8 N/m is 3.2e-4 too high (the
# 40-digit reference: 1.98023e-8).  Double precision cannot decide the closed loop there (arg F turns faster than it
# resolves: the crossing pole sits 4e-18 off the circle at K_cr(1 − 1e-6)); until issue 34's mpmath look
# (optim.stability.circle_reach) the answer was kept, said unconfirmed with no bound; now the closed loop decides it,
# in 50 digits, and the answer is refused (422 on device.cable, naming method 'reference').  In this regime the answers
# are chaotic: a probe cable at δ ≈ 1e-16 gave 1.19e-10 N/m against the 40-digit reference's 1.98e-10.
UNDECIDABLE = Device(mass=10.467717038195227, damping=6.42033885002709e-11, sample_time=0.0032546726120633654,
                     cable=dict(motor_mass=2.9508128219020167, motor_damping=2.6225363899531133e-11,
                                body_mass=7.51690421629321, body_damping=3.797802460073977e-11,
                                stiffness=10988.463865641284, damping=3.981325739080376e-19))


def test_an_answer_the_closed_loop_contradicts_in_mpmath_is_refused():
    from optim.stability.analysis import analyse_stability
    from optim.stability.reference import reference_critical_stiffness

    with pytest.raises(InputError) as exc:
        critical_stiffness(UNDECIDABLE, 0.0)
    assert exc.value.field == "device.cable" and "does not confirm" in str(exc.value) and "reference" in str(exc.value)
    # the 40-digit reference's answer is the one the closed loop confirms (its pole ∓1.3e-20 off the circle)
    ref = reference_critical_stiffness(UNDECIDABLE, 0.0).critical_stiffness
    assert ref == pytest.approx(1.980233512e-8, rel=1e-9)
    assert verify_critical_stiffness(UNDECIDABLE, 0.0, ref).verdict == "confirmed"
    # an ordinary damped cable keeps its claim
    assert analyse_stability(Device(preset="lhifam")).error_estimate == 1e-12
