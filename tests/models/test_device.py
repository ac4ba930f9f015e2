"""Device validation, presets and preset + override merging."""

from __future__ import annotations

import math

import pytest
from pydantic import ValidationError

from models.device import MAX_DELAY_SAMPLES, PRESETS, Device
from tests.reference_values import DEVICES


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_presets_match_chapter_table2(name):
    dev = Device(preset=name)
    ref = DEVICES[name]
    assert dev.sample_time == ref["sample_time"]
    for key, value in ref["cable"].items():
        assert getattr(dev.cable, key) == value
    c = ref["cable"]
    assert dev.mass == pytest.approx(c["motor_mass"] + c["body_mass"], rel=1e-15)
    if "rigid" in ref:  # Table 2's rigid m and b are the sums of the two-mass parameters
        assert dev.mass == pytest.approx(ref["rigid"]["mass"], rel=1e-15)
        assert dev.damping == pytest.approx(ref["rigid"]["damping"], rel=1e-15)


def test_override_merges_into_preset_and_null_removes_a_block():
    dev = Device(preset="lhifam", delay=0.003, cable={"stiffness": 38000.0})
    assert dev.delay == 0.003 and dev.cable.stiffness == 38000.0 and dev.cable.motor_mass == 0.3
    rigid = Device(preset="lhifam", cable=None)
    assert rigid.cable is None and rigid.mass == 5.4 and rigid.damping == 3.5


@pytest.mark.parametrize("body, field", [
    ({"mass": float("nan"), "damping": 1}, "mass"),
    ({"mass": math.inf, "damping": 1}, "mass"),
    ({"mass": 0, "damping": 1}, "mass"),
    ({"mass": 1, "damping": -1}, "damping"),
    ({"mass": 1, "damping": 1, "sample_time": 0}, "sample_time"),
    ({"mass": 1, "damping": 1, "delay": -1e-3}, "delay"),
    ({"mass": 1, "damping": 1, "wheels": 4}, "wheels"),
    ({"mass": 1, "damping": 1, "human": {"mass": 0, "damping": 1, "stiffness": 1}}, "human.mass"),
])
def test_bad_values_name_the_field(body, field):
    with pytest.raises(ValidationError) as err:
        Device(**body)
    locs = [".".join(str(p) for p in e["loc"]) for e in err.value.errors()]
    assert field in locs


def test_unknown_preset_and_inconsistent_sums_are_named():
    with pytest.raises(ValidationError, match="preset: unknown preset 'nope'"):
        Device(preset="nope")
    with pytest.raises(ValidationError, match="mass: with a cable block, mass must equal"):
        Device(preset="lhifam", mass=6.0)
    with pytest.raises(ValidationError, match="damping: with a cable block"):
        Device(preset="lhifam", damping=1.0)


def test_delay_cost_limit():
    Device(mass=1, damping=1, sample_time=1e-3, delay=MAX_DELAY_SAMPLES * 1e-3)
    with pytest.raises(ValidationError, match=f"delay/sample_time ≤ {MAX_DELAY_SAMPLES} samples"):
        Device(mass=1, damping=1, sample_time=1e-3, delay=(MAX_DELAY_SAMPLES + 1) * 1e-3)


def test_table1_dimensionless_numbers():
    dev = Device(mass=5.4, damping=3.5, sample_time=1e-3, delay=2.5e-3)
    assert dev.delta == pytest.approx(3.5e-3 / 5.4, rel=1e-15)
    assert dev.delay_samples == pytest.approx(2.5, rel=1e-15)
    assert dev.stiffness_scale == pytest.approx(5.4e6, rel=1e-15)
