"""The sampled plant G_1 of the force-feedforward loop (eq. 29): closed-form limits."""

from __future__ import annotations

import math

import numpy as np
import pytest

from models.device import Device
from models.feedforward import CHAPTER_HUMAN, feedforward_plant, feedforward_state_space
from tests.feedforward_reference import HUMAN_EQ30, LHIFAM_CABLE, LHIFAM_RIGID


def test_rigid_without_sensor_is_the_mass_ratio_at_high_frequency():
    """Z_h·G/(1 + Z_h·G) → m_h/(m + m_h) when inertia dominates (the flat part of Fig. 23, eq. 33)."""
    dev = Device(**LHIFAM_RIGID, human=HUMAN_EQ30)
    a, b, c, d = feedforward_state_space(dev, dev.human)
    assert d == pytest.approx(2.0 / 7.4, rel=1e-15)
    # continuous response at 300 rad/s: 1 + O((b/mω) , k_h/(m_h ω²))
    s = 300j * dev.sample_time
    g = c @ np.linalg.solve(s * np.eye(len(b)) - a, b) + d
    zh = 2 * (300j) ** 2 + 2 * 300j + 10
    exact = zh / (5.4 * (300j) ** 2 + 3.5 * 300j + zh)
    assert g == pytest.approx(exact, rel=1e-12)


def test_dc_gain_is_one_with_a_grasp_stiffness():
    """At s → 0 the grasp spring carries all the force: G_1(1) = 1 (k_h > 0)."""
    for dev in (Device(**LHIFAM_RIGID, human=HUMAN_EQ30, force_sensor={"time_constant": 0.005}),
                Device(**LHIFAM_CABLE, human=HUMAN_EQ30, force_sensor={"time_constant": 0.005})):
        g = feedforward_plant(dev, dev.human).response(np.array([1e-9]))[0]
        assert g == pytest.approx(1.0, rel=1e-6)


def test_stiff_cable_tends_to_the_rigid_model():
    """A cable 10⁷ times stiffer: mode at ω_n T ≈ 530 rad/sample, whose aliased replicas
    leave a residual ~1e-4 near Nyquist (measured 9e-5); 1e-3 bounds it."""
    cable = dict(LHIFAM_CABLE["cable"], stiffness=7.95e11, damping=0.0)
    stiff = Device(cable=cable, sample_time=1e-3, human=HUMAN_EQ30, force_sensor={"time_constant": 0.005})
    rigid = stiff.rigid()
    theta = np.array([0.01, 0.3, 1.0, 2.5])
    g_c = feedforward_plant(stiff, CHAPTER_HUMAN).response(theta)
    g_r = feedforward_plant(rigid, CHAPTER_HUMAN).response(theta)
    assert np.max(np.abs(g_c / g_r - 1)) <= 1e-3


def test_zero_grasp_stiffness_gives_a_minimal_rigid_realisation():
    dev = Device(**LHIFAM_RIGID, human={"mass": 2, "damping": 2, "stiffness": 0})
    a, _, _, _ = feedforward_state_space(dev, dev.human)
    assert a.shape == (1, 1)
    g = feedforward_plant(dev, dev.human).response(np.array([math.pi]))[0]
    assert np.isfinite(g)
