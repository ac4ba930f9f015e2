"""The design sections of docs/virtual_environment.md for a rendered wall over a box and over a workspace, and the
boundary figure with a controller (issue 30).

Computes every number those sections quote with the public numerics and checks each design independently (the robust
box: the rendered K_cr on a 6×6×6 grid over the box and verify's closed loops with the filter's states; the
workspace: the MIMO loop with the filter's states at the worst cases).  bench/virtual_environment_example.py calls
:func:`sections` to write the page; run alone it prints them:

    PYTHONPATH=. python -m bench.virtual_environment_designs
"""

from __future__ import annotations

import itertools
import math
import os
import time

import numpy as np

from models.device import Device
from models.kinematics import KINEMATIC_PRESETS, load_kinematics
from models.velocity_filter import LowPass, rendering
from optim.robust.box import UncertaintyBox
from optim.robust.rendered_stiffness import robust_rendered_stiffness
from optim.robust.stiffness import robust_design_stiffness
from optim.stability.rendered import rendered_critical_stiffness
from optim.stiffness import StiffnessRequirements
from optim.stiffness.rendered_design import design_rendered_stiffness
from optim.verification_robust import verify_robust_stiffness
from optim.workspace.design import design_workspace_stiffness, mimo_checks
from optim.workspace.workspace import lhs_poses

DEV = Device(mass=5.4, damping=3.5, sample_time=0.001, delay=0.0005)
RANGES = {"device.mass": (4.5, 6.5), "device.damping": (2.0, 5.0), "device.delay": (0.0002, 0.0008)}
GM = 6.0


def _label(spec, mass: float) -> str:
    v = "backward difference" if spec is None else f"low-pass {spec.cutoff_hz:g} Hz, order {spec.order}"
    return v + (f", M = {mass:g} kg" if mass else "")


def _robust() -> list[str]:
    box = UncertaintyBox.from_ranges(DEV, RANGES)
    req = StiffnessRequirements(min_gain_margin_db=GM)
    d0 = robust_design_stiffness(DEV, req, box)
    rows = [f"| {_label(None, 0.0)} (today's robust design) | {d0.stiffness:.6g} | {d0.damping:.6g} | "
            f"{d0.gain_margin_db:.9g} | — | — | — | — |"]
    axes = [np.linspace(lo, hi, 6) for lo, hi in RANGES.values()]
    kept = None
    for spec, mass in [(LowPass(kind="low_pass", cutoff_hz=50, order=1), 0.0),
                       (LowPass(kind="low_pass", cutoff_hz=100, order=2), 0.0), (None, -1.0),
                       (LowPass(kind="low_pass", cutoff_hz=50, order=1), 1.0)]:
        t0 = time.perf_counter()
        d = robust_rendered_stiffness(DEV, req, box, mass, spec)
        elapsed = time.perf_counter() - t0
        nominal = design_rendered_stiffness(DEV, req, mass, spec)
        grid = min(20 * math.log10(rendered_critical_stiffness(
            Device(mass=a, damping=b, sample_time=0.001, delay=c), d.damping,
            rendering(spec, mass, 0.001)).critical_stiffness / d.stiffness) for a, b, c in itertools.product(*axes))
        v = verify_robust_stiffness(box, d.stiffness, d.damping, GM, False, d.worst_case["device"], None, (spec, mass))
        w = d.worst_case["device"]
        if kept is None:
            kept = d.stiffness / d0.stiffness
        rows.append(f"| {_label(spec, mass)} | {d.stiffness:.6g} | {d.damping:.6g} | {d.gain_margin_db:.9g} | "
                    f"{nominal.stiffness:.6g} | {grid:.9g} | {v.verdict} | "
                    f"m = {w['device.mass']:g}, b = {w['device.damping']:g}, t_d = {w['device.delay'] * 1e3:g} ms; "
                    f"{d.evaluations} analyses, {elapsed:.2f} s |")
    return [
        "## Robust box with a rendered wall",
        "",
        "`requirements.uncertainty` (the box of device parameters) with a fixed `controller.velocity_filter`, "
        "`controller.mass` or a fixed `requirements.velocity_filter`: one (K, B) that keeps the margin on every "
        "device of the box, exact rung only (optim/robust/rendered_stiffness.py).  The scenario exchange of the "
        "robust design runs on the exact rendered K_cr of each device (its filter realised at that device's own "
        "sample time): the robust objective min(g·min_s K_cr(B; s), caps) over the scenarios is maximised over B by "
        "the exact B scan, the box's worst device at that B is searched with the rendered analysis (Sobol, corners, "
        "pattern search) and joins the scenarios until it meets the margin.  `verify` closes the loop with the "
        "filter's and the virtual mass's states at every corner and the worst device, and runs its independent "
        "interior search (Latin hypercube, Nelder–Mead, spectral radius of the rendered closed loop) over the box.  "
        "Refused with a 422 naming the field: a designed cutoff with a box (`requirements.velocity_filter.design`: "
        "the joint (cutoff, K, B) NLP over a box does not fit the time yet), `requirements.passivity` (the box's "
        "passivity is not decided for a rendered wall yet), the noise rules with an uncertain sample time, and a "
        "sample-time range that puts the cutoff at or above Nyquist (`requirements.uncertainty.device.sample_time`).",
        "",
        f"Rigid device m = 5.4 kg, b = 3.5 N·s/m, T = 1 ms, t_d = 0.5 ms; box m ∈ [4.5, 6.5] kg, b ∈ [2, 5] N·s/m, "
        f"t_d ∈ [0.2, 0.8] ms; 6 dB.  \"grid margin\": the smallest 20·log10(K_cr/K) over a 6×6×6 grid of the box "
        f"by the exact rendered analysis; verify: the design's closed-loop check (load {os.getloadavg()[0]:.1f}).",
        "",
        "| velocity | K [N/m] | B [N·s/m] | worst margin [dB] | nominal design's K [N/m] | grid margin [dB] | verify "
        "| worst device; cost |",
        "|---|---|---|---|---|---|---|---|",
        *rows,
        "",
        "The worst device is the light, least damped, most delayed corner here (the interior search ends there too); "
        f"with the 50 Hz filter the box design keeps {100 * kept:.0f} % of today's robust K.  "
        "tests/optim/robust/test_robust_rendered.py holds the 50 Hz and the M = −1 kg designs to a grid of the box by "
        "the rendered analysis and by closed-loop eigenvalues, and shows the interior search closes the loop with the "
        "filter (a gain between the filtered and the unfiltered worst K_cr: unstable found with the filter, none "
        "without).  docs/properties_robust_rendered.md: 30 random boxes, filters and virtual masses, each design held to a "
        "5×5×5 grid by the rendered analysis and the closed loop, and by verify (bench/robust_rendered_properties.py).",
        "",
    ]


def _workspace() -> list[str]:
    arm = load_kinematics(**KINEMATIC_PRESETS["planar-2link"])
    poses = lhs_poses(arm, 6, 3)
    normals = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.7071, 0.7071, 0.0]]
    t, td = 0.001, 0.001
    rows = []
    for spec in (None, LowPass(kind="low_pass", cutoff_hz=50, order=1), LowPass(kind="low_pass", cutoff_hz=20,
                                                                                  order=1)):
        r = None if spec is None else rendering(spec, 0.0, t)
        d = design_workspace_stiffness(arm, poses, normals, t, td, min_gain_margin_db=1.0, rendering=r)
        checks = mimo_checks(arm, d, t, td, r)
        rho = max(c.spectral_radius for c in checks)
        rows.append(f"| {_label(spec, 0.0)} | {d.stiffness:.6g} | {d.damping:.6g} | {d.status} | "
                    f"{d.verification_margin:.4g} | {len(checks)} | {rho:.9f} |")
    return [
        "## Workspace design with a rendered wall",
        "",
        "`requirements.workspace` with a fixed velocity filter or virtual mass: the exchange design over the poses "
        "and normals on the per-(pose, normal) plant G_n with C(z) = K + B·V(z) + M·A(z) "
        "(optim/workspace/wall_rendered.py: the rendered argument of optim.stability.rendered on G_n's modal sum, "
        "the K → 0⁺ loop decided by counting poles along B then M); `verify` closes the full MIMO loop with the "
        "filter's states, V(z) on the normal penetration (optim/workspace/mimo_loop.py, "
        "`rendered_closed_loop_matrix`).  The normals must be given: `normals: \"worst\"` with a filter is a 422 on "
        "`requirements.workspace.normals` (the worst-normal search is today's wall's), a designed cutoff a 422 on "
        "`requirements.velocity_filter.design`, and an undamped joint seen along a normal a 422 on "
        "`requirements.workspace.kinematics.joint_damping`.",
        "",
        "planar-2link preset, 6 Latin-hypercube poses (seed 3) × 3 normals, T = 1 ms, t_d = 1 ms, 1 dB; the "
        "verification on 24 more poses; the MIMO loop's spectral radius at (K, B) at the worst cases:",
        "",
        "| velocity | K [N/m] | B [N·s/m] | status | verification margin K_cr/K − 1 | MIMO checks | largest spectral "
        "radius |",
        "|---|---|---|---|---|---|---|",
        *rows,
        "",
        "tests/optim/workspace/test_wall_rendered.py: the one-mode plant equals the 1-DOF rendered analysis (1e-9), "
        "the backward difference equals today's workspace scan (1e-10), and on random poses and normals the MIMO "
        "loop is stable at K_cr·(1 − 1e-5) and unstable at K_cr·(1 + 1e-5) (50 Hz order 1, 80 Hz order 2, M = −0.05 "
        "kg).",
        "",
    ]


def _plot() -> list[str]:
    return [
        "## The boundary figure with a controller",
        "",
        "`POST /v1/plots/boundary` takes `controller: {mass, velocity_filter}` as `POST /v1/analysis/boundary` "
        "does: the figure is the rendered K_cr(B) (the same numerics, tests/service/test_plot_boundary_rendered.py "
        "compares the drawn line to them point by point), its title names the filter and M, and the filter's rules "
        "are 422s under `controller.` (a cutoff at or above Nyquist, a moving average of 0 samples, order 3).  It "
        "runs in a compute worker under the route's time budget like today's figure: a rendered cable boundary "
        "costs 11–19 ms per K_cr, so a long curve on the cable model can meet the budget's 503.",
        "",
    ]


def sections() -> list[str]:
    return _robust() + _workspace() + _plot()


if __name__ == "__main__":
    print("\n".join(sections()))
