"""Pinocchio's M(q) and J(q) of the planar 2-link preset against the textbook closed form, and the URDF's refusals."""

from __future__ import annotations

import math

import numpy as np
import pytest

from models.errors import InputError
from models.kinematics import KINEMATIC_PRESETS, MAX_URDF_CHARS, load_kinematics

# the preset's parameters (models/kinematics.py _planar_two_link): links, masses at the middles, rod inertias
L1, L2, M1, M2 = 0.30, 0.25, 1.0, 0.6
LC1, LC2 = L1 / 2, L2 / 2
I1, I2 = M1 * L1 ** 2 / 12, M2 * L2 ** 2 / 12


def textbook(q1: float, q2: float) -> tuple[np.ndarray, np.ndarray]:
    """Spong, Hutchinson & Vidyasagar, Robot Modeling and Control, §7.4 (two-link planar arm)."""
    c2 = math.cos(q2)
    m11 = I1 + I2 + M1 * LC1 ** 2 + M2 * (L1 ** 2 + LC2 ** 2 + 2 * L1 * LC2 * c2)
    m12 = I2 + M2 * (LC2 ** 2 + L1 * LC2 * c2)
    m22 = I2 + M2 * LC2 ** 2
    s1, s12, c1, c12 = math.sin(q1), math.sin(q1 + q2), math.cos(q1), math.cos(q1 + q2)
    jac = np.array([[-L1 * s1 - L2 * s12, -L2 * s12], [L1 * c1 + L2 * c12, L2 * c12], [0.0, 0.0]])
    return np.array([[m11, m12], [m12, m22]]), jac


def test_planar_two_link_against_closed_form():
    model = load_kinematics(**KINEMATIC_PRESETS["planar-2link"])
    rng = np.random.default_rng(7)
    worst_m = worst_j = worst_l = 0.0
    for _ in range(1000):
        q = rng.uniform(model.lower, model.upper)
        mass, jac = model.at(q)
        m_ref, j_ref = textbook(*q)
        worst_m = max(worst_m, float(np.max(np.abs(mass - m_ref))) / float(np.max(np.abs(m_ref))))
        worst_j = max(worst_j, float(np.max(np.abs(jac - j_ref))) / float(np.max(np.abs(j_ref))))
        jp, jr = jac[:2], j_ref[:2]                 # Λ = (J M⁻¹ Jᵀ)⁻¹ in the plane
        lam = np.linalg.inv(jp @ np.linalg.solve(mass, jp.T))
        lam_ref = np.linalg.inv(jr @ np.linalg.solve(m_ref, jr.T))
        worst_l = max(worst_l, float(np.max(np.abs(lam - lam_ref))) / float(np.max(np.abs(lam_ref))))
    assert worst_m < 1e-12 and worst_j < 1e-12 and worst_l < 1e-9, (worst_m, worst_j, worst_l)


def test_armature_and_joint_damping_override():
    model = load_kinematics(**KINEMATIC_PRESETS["planar-2link"], armature=[0.01, 0.02], joint_damping=[1.0, 2.0])
    mass, _ = model.at(np.array([0.2, 0.5]))
    m_ref, _ = textbook(0.2, 0.5)
    assert np.allclose(mass - m_ref, np.diag([0.01, 0.02]), rtol=0, atol=1e-14)
    assert list(model.joint_damping) == [1.0, 2.0]


@pytest.mark.parametrize(("urdf", "end", "field"), [
    ("<robot", "tip", "urdf"),
    ("not xml at all", "tip", "urdf"),
    (KINEMATIC_PRESETS["planar-2link"]["urdf"], "no-such-frame", "end_effector"),
    ('<?xml version="1.0"?><!DOCTYPE r [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;">]>'
     '<robot name="x"><link name="&b;"/></robot>', "tip", "urdf"),                       # entity expansion
    ('<?xml version="1.0"?><!DOCTYPE r [<!ENTITY x SYSTEM "file:///etc/passwd">]><robot name="&x;"/>',
     "tip", "urdf"),                                                                          # external entity
    ('<?xml version="1.0"?><robot name="x"><link name="a"/></robot>', "a", "urdf"),        # no joint
    ("<robot>" + " " * MAX_URDF_CHARS + "</robot>", "tip", "urdf"),
])
def test_bad_urdf_is_refused_naming_its_field(urdf, end, field):
    with pytest.raises(InputError) as err:
        load_kinematics(urdf, end)
    assert err.value.field == field


def test_zero_inertia_is_refused():
    urdf = ('<?xml version="1.0"?><robot name="x"><link name="base"/><link name="arm"/>'
            '<joint name="j" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>'
            '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>')
    with pytest.raises(InputError) as err:
        load_kinematics(urdf, "arm")
    assert err.value.field == "urdf" and "inertia" in err.value.rule


def test_wrong_length_armature():
    with pytest.raises(InputError) as err:
        load_kinematics(**KINEMATIC_PRESETS["planar-2link"], armature=[0.1])
    assert err.value.field == "armature"
