"""Reference values of the chapter's §5 used by the force-feedforward tests, each with source and tolerance.

The printed values come from tests/reference_values.py (the copy of the shared
seed_cases.json); the few §5.2 numbers that file does not hold are quoted here
from the chapter (Díaz, Gil & Hulin, §5.2) with their wording.
"""

from tests.reference_values import CASES, device_params

_EQ32 = CASES["eq32-KfCR-lhifam"]
_EQ33 = CASES["eq33-worst-case-Kf"]
_SEC52 = CASES["sec5.2-Kf5-apparent-mass"]

#: LHifAM rigid model (m = m_r + m_d, b = b_r + b_d) and two-mass cable model, chapter Table 2.
LHIFAM_RIGID = device_params("lhifam/rigid")
LHIFAM_CABLE = device_params("lhifam/cable")
#: Human of eq. 30 (Yokokohji & Yoshikawa): Z_h = 2 s² + 2 s + 10.
HUMAN_EQ30 = dict(_EQ32["human"])
#: Force-sensor filter of eq. 31: G_f = 1/(1 + 0.005 s).
SENSOR_EQ31 = dict(_EQ32["force_sensor"])

#: Eq. 32: K_f,cr = 37.12 at the Nyquist frequency; printed to 4 figures (rtol 1e-3).
EQ32_CRITICAL_FORCE_GAIN = _EQ32["printed"]
EQ32_RTOL = _EQ32["tolerance_rel"]
#: Eq. 33: worst case 1 + m/m_h = 3.7 (closed form).
EQ33_WORST_CASE = _EQ33["printed"]
#: §5.2: K_f = 5 gives 0.9 kg apparent mass (5.4/6).
SEC52_FORCE_GAIN = 5.0
SEC52_APPARENT_MASS = _SEC52["printed"]
#: §5.2: "a second-order Butterworth digital filter at 30 Hz", lower cutoff bound "about
#: 10 Hz" (human force bandwidth), "a significant resonant peak appears around 82 Hz".
SEC52_FILTER = {"cutoff_hz": 30.0, "order": 2}
SEC52_HUMAN_BANDWIDTH_HZ = 10.0
SEC52_MODE_HZ = 82.0
