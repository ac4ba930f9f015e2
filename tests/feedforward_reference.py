"""Reference values of the chapter's §5 used by the force-feedforward tests, each with source and tolerance.

Copied from the chapter (Díaz, Gil & Hulin, "Stability Boundary and Transparency
for Haptic Rendering", §5.1-5.2); tests never read ../shared at run time.
"""

#: LHifAM rigid model, chapter Table 2 (m = m_r + m_d, b = b_r + b_d), T = 1 ms.
LHIFAM_RIGID = {"mass": 5.4, "damping": 3.5, "sample_time": 0.001}
#: LHifAM two-mass cable model, chapter Table 2.
LHIFAM_CABLE = {"cable": {"motor_mass": 0.3, "motor_damping": 0.1, "body_mass": 5.1, "body_damping": 3.4,
                          "stiffness": 79500.0, "damping": 15.0}, "sample_time": 0.001}
#: Human of eq. 30 (Yokokohji & Yoshikawa): Z_h = 2 s² + 2 s + 10.
HUMAN_EQ30 = {"mass": 2.0, "damping": 2.0, "stiffness": 10.0}
#: Force-sensor filter of eq. 31: G_f = 1/(1 + 0.005 s).
SENSOR_EQ31 = {"time_constant": 0.005}

#: Eq. 32: K_f,cr = 37.12, phase crossover at the Nyquist frequency. The chapter
#: prints 4 significant figures; our exact value is 37.1231, so rtol 1e-3.
EQ32_CRITICAL_FORCE_GAIN = 37.12
EQ32_RTOL = 1e-3
#: Eq. 33: worst case 1 + m/m_h = 1 + 5.4/2 = 3.7 (closed form, exact up to rounding).
EQ33_WORST_CASE = 3.7
#: §5.2: K_f = 5 gives 0.9 kg apparent mass (5.4/6, exact up to rounding).
SEC52_FORCE_GAIN = 5.0
SEC52_APPARENT_MASS = 0.9
#: §5.2: the chapter's filter: 2nd-order Butterworth at 30 Hz; human force bandwidth
#: ≈ 10 Hz (lower bound of the cutoff); first cable mode "around 82 Hz" (eq. 24).
SEC52_FILTER = {"cutoff_hz": 30.0, "order": 2}
SEC52_HUMAN_BANDWIDTH_HZ = 10.0
SEC52_MODE_HZ = 82.0
