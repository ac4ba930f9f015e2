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


# The PHANToM Premium 1.5's closed-form joint-space inertia (Cavusoglu, Feygin & Tendick 2002; Cavusoglu & Feygin
# 2001, ERL memo M01/15; as coded in github.com/mahilab/Phantom, Model.cpp step_dynamics_cavusoglu) and its forward
# kinematics, with the parameters copied here (the test never reads the preset's table for its reference).
_PH = {"ma": 0.0202, "Iaxx": 0.4864e-4, "Iayy": 0.001843e-4, "Iazz": 0.4864e-4, "mc": 0.0249, "Icxx": 0.959e-4,
       "Icyy": 0.959e-4, "Iczz": 0.0051e-4, "Ibexx": 11.09e-4, "Ibeyy": 10.06e-4, "Ibezz": 0.591e-4,
       "Idfxx": 7.11e-4, "Idfyy": 0.629e-4, "Idfzz": 6.246e-4, "Ibaseyy": 11.87e-4, "l1": 0.215, "l2": 0.170,
       "l3": 0.0325}


def phantom_closed_form(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    p = _PH
    ma, mc, l1, l2, l3 = p["ma"], p["mc"], p["l1"], p["l2"], p["l3"]
    _, q2, q3 = q
    m11 = (0.125 * (4 * p["Iayy"] + 4 * p["Iazz"] + 8 * p["Ibaseyy"] + 4 * p["Ibeyy"] + 4 * p["Ibezz"]
                    + 4 * p["Icyy"] + 4 * p["Iczz"] + 4 * p["Idfyy"] + 4 * p["Idfzz"] + 4 * l1 ** 2 * ma
                    + l2 ** 2 * ma + l1 ** 2 * mc + 4 * l3 ** 2 * mc)
           + 0.125 * (4 * p["Ibeyy"] - 4 * p["Ibezz"] + 4 * p["Icyy"] - 4 * p["Iczz"] + l1 ** 2 * (4 * ma + mc))
           * math.cos(2 * q2)
           + 0.125 * (4 * p["Iayy"] - 4 * p["Iazz"] + 4 * p["Idfyy"] - 4 * p["Idfzz"] - l2 ** 2 * ma
                      - 4 * l3 ** 2 * mc) * math.cos(2 * q3)
           + l1 * (l2 * ma + l3 * mc) * math.cos(q2) * math.sin(q3))
    m22 = 0.25 * (4 * (p["Ibexx"] + p["Icxx"] + l1 ** 2 * ma) + l1 ** 2 * mc)
    m23 = -0.5 * l1 * (l2 * ma + l3 * mc) * math.sin(q2 - q3)
    m33 = 0.25 * (4 * p["Iaxx"] + 4 * p["Idfxx"] + l2 ** 2 * ma + 4 * l3 ** 2 * mc)
    mass = np.array([[m11, 0.0, 0.0], [0.0, m22, m23], [0.0, m23, m33]])

    def tip(x: np.ndarray) -> np.ndarray:
        r = l1 * math.cos(x[1]) + l2 * math.sin(x[2])
        return np.array([math.sin(x[0]) * r, l2 - l2 * math.cos(x[2]) + l1 * math.sin(x[1]),
                         -l1 + math.cos(x[0]) * r])

    h = 1e-6   # the Jacobian by central differences of the closed-form position (truncation ~1e-13)
    jac = np.stack([(tip(q + h * e) - tip(q - h * e)) / (2 * h) for e in np.eye(3)], axis=1)
    return mass, jac


def test_phantom_premium_against_the_papers_closed_form():
    model = load_kinematics(**KINEMATIC_PRESETS["phantom-premium-1.5"])
    assert model.joint_names == ("q1", "q2", "q3")
    rng = np.random.default_rng(11)
    worst_m = worst_j = 0.0
    for _ in range(1000):
        q = rng.uniform(model.lower, model.upper)
        mass, jac = model.at(q)
        m_ref, j_ref = phantom_closed_form(q)
        worst_m = max(worst_m, float(np.max(np.abs(mass - m_ref))) / float(np.max(np.abs(m_ref))))
        worst_j = max(worst_j, float(np.max(np.abs(jac - j_ref))) / float(np.max(np.abs(j_ref))))
    assert worst_m < 1e-12
    assert worst_j < 1e-8      # the reference is a finite difference
