"""The workspace design of a rendered wall (issue 30): optim.workspace.wall_rendered's K_cr on the per-(pose, normal)
plant with a velocity filter and virtual mass, held to (a) the 1-DOF rendered analysis on a one-mode plant, (b) today's
wall's scan with the backward difference, and (c) the full MIMO loop with the filter's states
(optim.workspace.mimo_loop.rendered_closed_loop_matrix, eigenvalues: no modal decomposition, no crossover scan) just
below and above each K_cr; the design's K and verify's MIMO checks at its worst cases."""

from __future__ import annotations

import numpy as np
import pytest

from models.device import Device
from models.kinematics import KINEMATIC_PRESETS, load_kinematics
from models.velocity_filter import LowPass, MovingAverage, rendering
from optim.errors import InputError
from optim.stability.rendered import rendered_critical_stiffness, rendered_max_stable_damping
from optim.workspace.design import design_workspace_stiffness, mimo_checks
from optim.workspace.mimo_loop import rendered_wall_spectral_radius
from optim.workspace.wall_plant import WallModes, wall_critical_stiffness, wall_modes
from optim.workspace.wall_rendered import RenderedWall
from optim.workspace.workspace import lhs_poses

T, TD = 0.001, 0.0007
LP50 = LowPass(kind="low_pass", cutoff_hz=50, order=1)
LP80_2 = LowPass(kind="low_pass", cutoff_hz=80, order=2)
NORMALS = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.7071, 0.7071, 0.0]]


@pytest.fixture(scope="module")
def arm():
    return load_kinematics(**KINEMATIC_PRESETS["planar-2link"])


@pytest.mark.parametrize("spec,mass", [(LP50, 0.0), (LP80_2, -0.5), (MovingAverage(kind="moving_average", samples=4),
                                                                    0.3)])
def test_one_mode_equals_the_one_dof_rendered_analysis(spec, mass):
    m, b = 2.0, 1.5
    wall = RenderedWall(WallModes((1 / m,), (b / m,)), T, TD, rendering(spec, mass, T))
    dev = Device(mass=m, damping=b, sample_time=T, delay=TD)
    r = rendering(spec, mass, T)
    assert wall.max_stable_damping() == pytest.approx(rendered_max_stable_damping(dev, r), rel=1e-9)
    for damping in (0.0, 5.0, 20.0):
        assert wall.critical(damping).critical_stiffness == pytest.approx(
            rendered_critical_stiffness(dev, damping, r).critical_stiffness, rel=1e-9)


def test_backward_difference_is_todays_wall(arm):
    mass, jac = arm.at(np.array([0.4, 1.1]))
    modes = wall_modes(mass, jac, arm.joint_damping, np.array([0.6, 0.8, 0.0]))
    wall = RenderedWall(modes, T, TD, rendering(None, 0.0, T))
    for damping in (0.0, 2.0, 30.0):
        assert wall.critical(damping).critical_stiffness == pytest.approx(
            wall_critical_stiffness(modes, T, TD, damping).critical_stiffness, rel=1e-10)


@pytest.mark.parametrize("spec,mass", [(LP50, 0.0), (LP80_2, 0.0), (LP50, -0.05)])
def test_critical_stiffness_is_the_mimo_loops_boundary(arm, spec, mass):
    rng = np.random.default_rng(7)
    r = rendering(spec, mass, T)
    for _ in range(4):
        q = rng.uniform(-2.5, 2.5, 2)
        n = np.array([*rng.normal(size=2), 0.0])
        n /= np.linalg.norm(n)
        m_q, jac = arm.at(q)
        wall = RenderedWall(wall_modes(m_q, jac, arm.joint_damping, n), T, TD, r)
        damping = 0.3 * wall.max_stable_damping()
        kcr = wall.critical(damping).critical_stiffness
        assert 0 < kcr < np.inf

        def rho(k):
            return rendered_wall_spectral_radius(m_q, jac, arm.joint_damping, n, k, damping, T, TD, spec, mass)
        assert rho(kcr * (1 - 1e-5)) < 1.0 < rho(kcr * (1 + 1e-5)), (q, n)


def test_design_holds_on_the_mimo_loop(arm):
    poses = lhs_poses(arm, 4, 3)
    r = rendering(LP50, 0.0, T)
    d = design_workspace_stiffness(arm, poses, NORMALS, T, TD, min_gain_margin_db=1.0, verify_factor=1, rendering=r)
    assert d.status == "verified", d.reason
    plain = design_workspace_stiffness(arm, poses, NORMALS, T, TD, min_gain_margin_db=1.0, verify_factor=1)
    assert d.stiffness < plain.stiffness          # the filter's lag costs stiffness
    checks = mimo_checks(arm, d, T, TD, r)
    assert checks and all(c.stable for c in checks)
    # the margin: the gain 10^(1/20)·K is still stable on the MIMO loop at every worst case, and K_cr sits at it
    for c in d.worst_cases:
        m_q, jac = arm.at(np.array(c.pose))
        n = np.array(c.normal)
        rho = rendered_wall_spectral_radius(m_q, jac, arm.joint_damping, n, d.stiffness * 10 ** (1 / 20) * (1 - 1e-6),
                                            d.damping, T, TD, LP50)
        assert rho < 1.0
    assert min(c.critical_stiffness for c in d.worst_cases) == pytest.approx(d.stiffness * 10 ** (1 / 20), rel=1e-9)


def test_worst_normals_and_undamped_joints_are_refused_naming_the_field(arm):
    r = rendering(LP50, 0.0, T)
    with pytest.raises(InputError) as exc:
        design_workspace_stiffness(arm, lhs_poses(arm, 2, 3), "worst", T, TD, rendering=r)
    assert exc.value.field == "normals"
    mass, jac = arm.at(np.array([0.4, 1.1]))
    with pytest.raises(InputError) as exc:
        RenderedWall(wall_modes(mass, jac, np.zeros(2), np.array([1.0, 0.0, 0.0])), T, TD, r)
    assert exc.value.field.endswith("joint_damping")
