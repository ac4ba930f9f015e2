"""Robust inertia design (issue 12): K_f and cutoff verified on the whole box, against optim.transparency.inertia's own
grasp-range design and a dense (cutoff × box grid) search."""

import itertools
import math

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from models.device import Device
from models.feedforward import feedforward_plant
from optim.robust.box import UncertaintyBox
from optim.robust.inertia import robust_design_inertia
from optim.robust.stiffness import TOLERANCE_DB
from optim.transparency.feedforward import critical_force_gain_of_plant, resolve_human
from optim.transparency.inertia import InertiaRequirements, design_inertia

LH = Device(preset="lhifam")


def kf_cr(device: Device, cutoff_hz: float, order: int = 2) -> float:
    """Exact K_f,cr of one device at one cutoff (optim.transparency.feedforward, independent of the robust code)."""
    human, _ = resolve_human(device)
    theta_c = 2 * math.pi * cutoff_hz * device.sample_time
    return critical_force_gain_of_plant(feedforward_plant(device, human), theta_c, order)[0]


def min_margin(box, d, n_random, seed=5):
    rng = np.random.default_rng(seed)
    pts = np.concatenate([box.corners(), box.lower + rng.random((n_random, box.dim)) * (box.upper - box.lower)])
    k = np.array([kf_cr(dev, d.filter_cutoff_hz) for dev in box.devices(pts)])
    return float(np.min(20 * np.log10(k / d.force_gain)))


@pytest.fixture(scope="module")
def two_param():
    box = UncertaintyBox.from_ranges(LH, {"device.human.mass": (0.5, 4.0), "device.cable.stiffness": (40000, 100000)})
    return box, robust_design_inertia(LH, InertiaRequirements(), box)


@pytest.mark.slow
def test_grasp_mass_range_matches_optim_inertia():
    """A box over the grasp mass alone is what optim.transparency.inertia's human_mass_range does (its own exchange)."""
    box = UncertaintyBox.from_ranges(LH, {"device.human.mass": (0.5, 4.0)})
    r = robust_design_inertia(LH, InertiaRequirements(), box)
    ref = design_inertia(LH, InertiaRequirements(human_mass_range={"min": 0.5, "max": 4.0}))
    assert r.status == ref.status == "optimal"
    # both end on the exact K_f,cr of the same worst grasp at the same cutoff
    assert r.force_gain == pytest.approx(ref.force_gain, rel=1e-7)
    assert r.filter_cutoff_hz == pytest.approx(ref.filter_cutoff_hz, rel=1e-7)


@pytest.mark.slow
def test_margin_holds_on_corners_and_2000_random_points(two_param):
    box, d = two_param
    assert d.status == "optimal", d.reason
    assert min_margin(box, d, 2000) >= 6.0 - TOLERANCE_DB
    assert d.gain_margin_db == pytest.approx(6.0, abs=1e-6)
    assert d.nominal_gain_margin_db > 6.0


@pytest.mark.slow
def test_not_over_conservative(two_param):
    """Dense search: best over the cutoff scan of min over a 9×9 grid of the box of K_f,cr/ρ."""
    box, d = two_param
    rho = 10 ** (6 / 20)
    axes = [np.linspace(lo, hi, 9) for lo, hi in zip(box.lower, box.upper)]
    devices = box.devices(np.array(list(itertools.product(*axes))))
    lo, hi = d.cutoff_band_hz
    best = max(min(kf_cr(dev, c) for dev in devices) / rho for c in np.geomspace(lo, hi, 9))
    assert best <= d.force_gain * (1 + 1e-3)


@pytest.mark.slow
def test_target_apparent_mass_keeps_margin_on_box():
    box = UncertaintyBox.from_ranges(LH, {"device.delay": (0.0, 0.001)})
    d = robust_design_inertia(LH, InertiaRequirements(target_apparent_mass=1.5), box)
    assert d.status == "optimal" and d.force_gain == pytest.approx(LH.mass / 1.5 - 1, rel=1e-12)
    assert min_margin(box, d, 300) >= 6.0 - TOLERANCE_DB
    # the highest such cutoff: 1 % higher, some device of the box loses the margin
    worse = min(kf_cr(dev, d.filter_cutoff_hz * 1.01) for dev in box.devices(np.linspace(0, 0.001, 41)[:, None]))
    assert 20 * math.log10(worse / d.force_gain) < 6.0


# ---- an uncertain sample time: one cutoff in Hz, each device at its own angle 2π·f_c·T ---------------------------

T_BOXES = {
    # min_apparent_mass: the lowest cutoff of the band wins here, the worst device is the slowest, softest cable
    "T-kc": ({"device.sample_time": (0.0005, 0.001), "device.cable.stiffness": (40000.0, 100000.0)},
             InertiaRequirements()),
    # target_apparent_mass: the highest cutoff that keeps the margin on every T and delay
    "T-delay-target": ({"device.sample_time": (0.0008, 0.0012), "device.delay": (0.0, 0.001)},
                       InertiaRequirements(target_apparent_mass=1.5)),
}


@pytest.fixture(scope="module")
def t_designs():
    out = {}
    for name, (ranges, req) in T_BOXES.items():
        box = UncertaintyBox.from_ranges(LH, ranges)
        out[name] = (box, req, robust_design_inertia(LH, req, box))
    return out


@pytest.mark.slow
@pytest.mark.parametrize("name", list(T_BOXES))
def test_sample_time_margin_holds_on_corners_and_2000_random_points(t_designs, name):
    box, req, d = t_designs[name]
    assert d.status == "optimal", d.reason
    assert min_margin(box, d, 2000, seed=11) >= req.min_gain_margin_db - TOLERANCE_DB
    assert d.gain_margin_db == pytest.approx(6.0, abs=1e-6)
    # the worst device, re-checked at its own angle 2π·f_c·T
    worst = box.device_at(list(d.worst_case["device"].values()))
    assert kf_cr(worst, d.filter_cutoff_hz) == pytest.approx(d.critical_force_gain, rel=1e-9)


@pytest.mark.slow
def test_sample_time_min_apparent_mass_not_over_conservative(t_designs):
    """Dense search: the best over a cutoff scan (refined) of min over a grid of the box of K_f,cr/ρ is within
    1e-3 of the design, and not below it (the grid's devices are devices of the box)."""
    box, req, d = t_designs["T-kc"]
    rho = 10 ** (req.min_gain_margin_db / 20)
    axes = [np.linspace(0.0005, 0.001, 9), np.linspace(40000.0, 100000.0, 5)]
    devices = box.devices(np.array(list(itertools.product(*axes))))

    def best_gain(c: float, devs=devices) -> float:
        return min(kf_cr(dev, c) for dev in devs) / rho

    lo, hi = d.cutoff_band_hz
    cutoffs = np.geomspace(lo, hi, 17)
    vals = [best_gain(c) for c in cutoffs]
    i = int(np.argmax(vals))
    a, b = math.log(cutoffs[max(i - 1, 0)]), math.log(cutoffs[min(i + 1, len(cutoffs) - 1)])
    near = [dev for dev in devices if kf_cr(dev, cutoffs[i]) <= 1.05 * vals[i] * rho]
    res = minimize_scalar(lambda x: -best_gain(math.exp(x), near), bounds=(a, b), method="bounded",
                          options={"xatol": 1e-10})
    dense = max(vals[i], best_gain(math.exp(res.x)))
    assert dense <= d.force_gain * (1 + 1e-3)
    assert d.force_gain <= dense * (1 + 1e-6)


@pytest.mark.slow
def test_sample_time_target_cutoff_is_the_highest(t_designs):
    """1e-3 above the design's cutoff some device of a grid over T (and t_d) loses the margin; at it none does."""
    box, req, d = t_designs["T-delay-target"]
    assert d.force_gain == pytest.approx(LH.mass / 1.5 - 1, rel=1e-12)
    devices = box.devices(np.array(list(itertools.product(np.linspace(0.0008, 0.0012, 9), [0.0, 0.0005, 0.001]))))

    def worst_db(c: float) -> float:
        return 20 * math.log10(min(kf_cr(dev, c) for dev in devices) / d.force_gain)

    assert worst_db(d.filter_cutoff_hz) >= 6.0 - TOLERANCE_DB
    assert worst_db(d.filter_cutoff_hz * (1 + 1e-3)) < 6.0


@pytest.mark.slow
def test_one_sample_time_is_the_nominal_design():
    """A box of one sample time (other than the nominal device's): optim.transparency.inertia's design of that device."""
    box = UncertaintyBox.from_ranges(LH, {"device.sample_time": (0.0008, 0.0008)})
    for req in (InertiaRequirements(), InertiaRequirements(target_apparent_mass=1.5)):
        r = robust_design_inertia(LH, req, box)
        n = design_inertia(LH.model_copy(update={"sample_time": 0.0008}), req)
        assert r.force_gain == pytest.approx(n.force_gain, rel=1e-9)
        assert r.filter_cutoff_hz == pytest.approx(n.filter_cutoff_hz, rel=1e-9)


@pytest.mark.slow
def test_pareto_and_rigid_comparison(two_param, t_designs):
    """The scan of the last round (worst over the scenarios) and the rigid model of the worst device."""
    box, d = two_param
    rho = 10 ** (6 / 20)
    assert len(d.pareto) == InertiaRequirements().pareto_points
    scen = box.devices(np.array([list(p.values()) for p in d.scenarios]))
    for p in d.pareto[::4]:
        assert p.critical_force_gain == pytest.approx(min(kf_cr(dev, p.filter_cutoff_hz) for dev in scen), rel=1e-9)
        assert p.force_gain == pytest.approx(p.critical_force_gain / rho, rel=1e-12)
    # at the design's cutoff (the band's lower end here) the scan agrees with the whole box's worst device
    assert d.pareto[0].filter_cutoff_hz == pytest.approx(d.filter_cutoff_hz, rel=1e-12)
    assert d.pareto[0].critical_force_gain == pytest.approx(d.critical_force_gain, rel=1e-9)
    worst = box.device_at(list(d.worst_case["device"].values()))
    rigid = kf_cr(worst.rigid(), d.filter_cutoff_hz)
    assert d.rigid_model.critical_force_gain == pytest.approx(rigid, rel=1e-9)
    assert d.rigid_model.optimism == pytest.approx(rigid / d.critical_force_gain - 1, rel=1e-9)
    # a rigid device has no comparison
    _, _, dt = t_designs["T-kc"]
    assert dt.rigid_model is not None
    rb = UncertaintyBox.from_ranges(LH.rigid(), {"device.sample_time": (0.0005, 0.002)})
    assert robust_design_inertia(LH.rigid(), InertiaRequirements(), rb).rigid_model is None


def test_cutoff_above_a_corners_nyquist_is_a_named_error():
    box = UncertaintyBox.from_ranges(LH, {"device.sample_time": (0.0005, 0.002)})
    with pytest.raises(ValueError, match=r"^requirements\.cutoff_max_hz: must be below the Nyquist"):
        robust_design_inertia(LH, InertiaRequirements(cutoff_max_hz=300.0), box)
