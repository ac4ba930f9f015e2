"""Robust inertia design (issue 12): K_f and cutoff verified on the whole box, against optim.inertia's own
grasp-range design and a dense (cutoff × box grid) search."""

import itertools
import math

import numpy as np
import pytest

from models.device import Device
from models.feedforward import feedforward_plant
from optim.feedforward import critical_force_gain_of_plant, resolve_human
from optim.inertia import InertiaRequirements, design_inertia
from optim.robust.box import UncertaintyBox
from optim.robust.inertia import robust_design_inertia
from optim.robust.stiffness import TOLERANCE_DB

LH = Device(preset="lhifam")


def kf_cr(device: Device, cutoff_hz: float, order: int = 2) -> float:
    """Exact K_f,cr of one device at one cutoff (optim.feedforward, independent of the robust code)."""
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


def test_grasp_mass_range_matches_optim_inertia():
    """A box over the grasp mass alone is what optim.inertia's human_mass_range does (its own exchange)."""
    box = UncertaintyBox.from_ranges(LH, {"device.human.mass": (0.5, 4.0)})
    r = robust_design_inertia(LH, InertiaRequirements(), box)
    ref = design_inertia(LH, InertiaRequirements(human_mass_range=(0.5, 4.0)))
    assert r.status == ref.status == "optimal"
    # both end on the exact K_f,cr of the same worst grasp at the same cutoff
    assert r.force_gain == pytest.approx(ref.force_gain, rel=1e-7)
    assert r.filter_cutoff_hz == pytest.approx(ref.filter_cutoff_hz, rel=1e-7)


def test_margin_holds_on_corners_and_2000_random_points(two_param):
    box, d = two_param
    assert d.status == "optimal", d.reason
    assert min_margin(box, d, 2000) >= 6.0 - TOLERANCE_DB
    assert d.gain_margin_db == pytest.approx(6.0, abs=1e-6)
    assert d.nominal_gain_margin_db > 6.0


def test_not_over_conservative(two_param):
    """Dense search: best over the cutoff scan of min over a 9×9 grid of the box of K_f,cr/ρ."""
    box, d = two_param
    rho = 10 ** (6 / 20)
    axes = [np.linspace(lo, hi, 9) for lo, hi in zip(box.lower, box.upper)]
    devices = box.devices(np.array(list(itertools.product(*axes))))
    lo, hi = d.cutoff_band_hz
    best = max(min(kf_cr(dev, c) for dev in devices) / rho for c in np.geomspace(lo, hi, 9))
    assert best <= d.force_gain * (1 + 1e-3)


def test_target_apparent_mass_keeps_margin_on_box():
    box = UncertaintyBox.from_ranges(LH, {"device.delay": (0.0, 0.001)})
    d = robust_design_inertia(LH, InertiaRequirements(target_apparent_mass=1.5), box)
    assert d.status == "optimal" and d.force_gain == pytest.approx(LH.mass / 1.5 - 1, rel=1e-12)
    assert min_margin(box, d, 300) >= 6.0 - TOLERANCE_DB
    # the highest such cutoff: 1 % higher, some device of the box loses the margin
    worse = min(kf_cr(dev, d.filter_cutoff_hz * 1.01) for dev in box.devices(np.linspace(0, 0.001, 41)[:, None]))
    assert 20 * math.log10(worse / d.force_gain) < 6.0


def test_sample_time_is_refused():
    box = UncertaintyBox.from_ranges(LH, {"device.sample_time": (0.0005, 0.001)})
    with pytest.raises(ValueError, match="requirements.uncertainty.device.sample_time"):
        robust_design_inertia(LH, InertiaRequirements(), box)
