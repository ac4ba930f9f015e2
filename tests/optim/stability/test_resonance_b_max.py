"""A known wrong answer, kept failing on purpose until it is fixed (issue 34, found 2026-12-03 by the lead).

A damped cable whose resonance pole lies within ~5e-8 of the unit circle (cable damping ratio ~2e-8) with a long
delay (163.5 samples): the virtual damper alone pushes that pole out of the circle at B ≈ 0.0127903 N·s/m, but the
exact rung (compiled cable brackets; main's bounded scan gave the same) reports B_max = 0.031414 N·s/m and, at
B = 0.0314023, K_cr = 0.0045319 N/m "stable below". The closed-loop verify in double precision (argument principle)
agreed with the wrong answer; bench/bench_cable.py's 5,000-cable run caught it only because its step happened to
land on the right side (docs/properties_analysis.md, "Cable fast path").

Reference values (50-digit mpmath, this device, the reference rung's own exact ZOH with the fractional delay):
- the damper-only loop (K → 0⁺) near θ = 2.5695383 rad/sample: Im of (−1/G)/(1 − e^{−jθ}) vanishes at
  θ = 2.56953829058208, B = 0.0127903440340882 N·s/m;
- Newton root tracking of 1 + (α + β(1 − z⁻¹))·G(z) = 0 from e^{jθ} (residual < 1e-40): at K → 0⁺ the root has
  |z| − 1 = −4.05e-10 at B = 0.0127, +4.91e-10 at B = 0.0129 and +8.34e-8 at B = 0.0314 (unchanged to 1e-11 for
  0 ≤ K ≤ 2·0.0045319 N/m): at B = 0.0314023 no small K is stable.
The fix (not made): solve the crossings next to each cable pole that lies within the scan's resolution of the circle
(first-order perturbation z ≈ p − (α + β(1 − p⁻¹))·R at the pole's residue R gives them in closed form), in the
brackets, the bounded scan and verify's argument principle alike.
"""

import pytest

from models.device import Device
from optim.stability.analysis import analyse_stability

DEVICE = {"mass": 9.227630257484549, "damping": 1.1926948188747691e-05, "sample_time": 0.002,
          "delay": 0.32703054165799533,
          "cable": {"motor_mass": 7.921220758518302, "motor_damping": 9.040275316094e-06,
                    "body_mass": 1.3064094989662465, "body_damping": 2.8866728726536906e-06,
                    "stiffness": 1851106.8878295596, "damping": 6.197968509007329e-05}}
#: B at which the damper-only loop's pole next to the resonance leaves the circle (50-digit mpmath, docstring)
TRUE_B_MAX_BOUND = 0.0127903440340882


@pytest.mark.xfail(strict=True, reason="issue 34: B_max next to a resonance within 5e-8 of the unit circle is "
                                       "2.46x too high (module docstring); strict: passes once fixed, then drop xfail")
def test_b_max_next_to_a_resonance_on_the_circle_is_not_overstated():
    a = analyse_stability(Device(**DEVICE), None, 0.03140229565265541, "exact")
    assert a.max_stable_damping is None or a.max_stable_damping <= TRUE_B_MAX_BOUND * (1 + 1e-6)
    # and no "stable below K_cr" where no small K is stable
    assert a.critical_stiffness in (None, 0.0) or a.error_estimate is None or a.error_estimate == float("inf")
