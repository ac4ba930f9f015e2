"""Cable K_cr a hair below B_max (design property run of 2026-12-01, seed 17, cases 749, 1877, 2741).

The cable brackets answered "no crossover" (K_cr = ∞) at B 1e-10–1e-9 below B_max, and B_max itself 3e-7 too
high on a cable with δ = 1e-9 (where K_cr = 0 by the 40-digit reference rung and the closed loop).  K_cr there now
comes from the bounded scan (margins.NEAR_B_MAX) and B_max from the bounded scan; each answer is held to the full
crossover scan and to the independent closed loop (optim.verification).
"""

from __future__ import annotations

import math

import pytest

from models.device import Device
from optim.stability.margins import critical_stiffness, max_stable_damping, scan_critical_stiffness
from optim.verification import verify_critical_stiffness

CASES = [
    ({"mass": 2.0849091589098023, "damping": 0.01823243349492078, "sample_time": 5.506849538662987e-05,
      "delay": 0.025580470632443522, "cable": {"motor_mass": 0.12212925276718568, "motor_damping": 0.0,
                                               "body_mass": 1.9627799061426168,
                                               "body_damping": 0.01823243349492078,
                                               "stiffness": 17775.405351985108, "damping": 0.0}},
     8.901251664922203e-05),
    ({"mass": 1.6929786241598903, "damping": 0.0, "sample_time": 0.0018301773755917258,
      "delay": 10.396970655944315, "cable": {"motor_mass": 1.3728220909745399, "motor_damping": 0.0,
                                             "body_mass": 0.3201565331853504, "body_damping": 0.0,
                                             "stiffness": 1288.9348771558964, "damping": 2.16388514640593e-05}},
     0.0008097803972023108),
    ({"mass": 0.8975704262717721, "damping": 2.402701982377408e-07, "sample_time": 0.00373793926679845,
      "delay": 4.083838388302691, "cable": {"motor_mass": 0.04150191194398012, "motor_damping": 0.0,
                                            "body_mass": 0.856068514327792, "body_damping": 2.402701982377408e-07,
                                            "stiffness": 958.9711211600941, "damping": 0.0}},
     9.996035693517128e-09),
]


@pytest.mark.parametrize("kw,b", CASES, ids=["1877", "749", "2741"])
def test_cable_k_cr_just_below_b_max_agrees_with_the_scan_and_the_closed_loop(kw, b):
    dev = Device(**kw)
    res = critical_stiffness(dev, b)
    assert math.isfinite(res.critical_stiffness)          # was ∞ ("every positive stiffness is stable")
    scan = scan_critical_stiffness(dev, b).critical_stiffness
    assert res.critical_stiffness == pytest.approx(scan, rel=1e-9, abs=1e-300)
    v = verify_critical_stiffness(dev, b, res.critical_stiffness)
    assert v.verdict != "contradicted", v


def test_b_max_of_the_lightly_damped_cable_is_below_the_b_where_the_loop_is_dead():
    dev, b = Device(**CASES[2][0]), CASES[2][1]
    assert max_stable_damping(dev) < b                      # K_cr(b) = 0: b is at or above the true B_max
    assert critical_stiffness(dev, b).critical_stiffness == 0.0

