"""The required damping is a proven upper bound of sup P (issue 34): against an independent mpmath sup.

tests/optim/stability/passivity_mp.py computes the sup its own way (another form of P, another grid, 32-digit
Newton); tests/optim/stability/passivity_cases.py draws random walls and walls aimed at the label (b within
1e-13–1e-5 of the sup, nearly equal lobes, delays up to 5,000 samples, fractional delays).  For each:

* ``passivity_margin``: required ≥ the sup (never on the unsafe side) and required − sup ≤ its ``error_bound``;
  a wrong label is ``passive: true`` with b ≤ sup, or ``passive: false`` with b above required's own bound
  (b > sup + error_bound).  ``passive: false`` with b in (sup, sup + error_bound] is the stated conservatism,
  counted apart.
* ``largest_passive_stiffness`` on the aimed walls: its K, backed off by 1e-8 as a design is, passive by the
  mpmath sup;
* ``verify_passivity`` (its own proof) on a share of them, given the analysis' label: it must never confirm a wrong
  label nor contradict a right one; not_checkable only within its band.

The full run (bench/bench_passivity.py: 5,000 random + 1,000 aimed) is in docs/properties_analysis.md.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from models.device import Device
from optim.stability.kernels import compile_kernels
from optim.stability.passivity import largest_passive_stiffness, passivity_margin, passivity_samples
from optim.verification import verify_passivity, whole_delay_samples

from .passivity_cases import aimed_wall, random_wall, whole_samples
from .passivity_mp import mp_sup

#: the issue's example: zwidth required 29962.6817 (passive: true); the sup is 29962.7704 at θ = 0.10825
EXAMPLE = (Device(sample_time=1.16184710959797e-05, delay=0.0003253171906874316, mass=6.442665896890286,
                  damping=29962.72), 680339.6224449361, 29958.72929925067)


def run_passivity_property(n_random: int, n_aimed: int, seed: int, verify_every: int = 1) -> dict:
    compile_kernels()
    rng = np.random.default_rng(seed)
    out = {"random": 0, "aimed": 0, "wrong_labels": [], "bound_violations": [], "conservative": 0,
           "passive": 0, "not_passive": 0, "verified": 0, "verify": {"confirmed": 0, "contradicted": 0,
                                                                     "not_checkable": 0},
           "verify_wrong": [], "max_rel_err": 0.0, "max_rel_bound": 0.0, "max_d": 0, "fractional": 0,
           "ms": [], "verify_ms": [], "ref_ms": [], "passive_k_checked": 0, "passive_k_unsafe": []}
    for i in range(n_random + n_aimed):
        t0 = time.perf_counter()
        if i < n_random:
            dev, k, big_b = random_wall(rng)
            sup = None
            out["random"] += 1
        else:
            dev, k, big_b, sup = aimed_wall(rng)
            out["aimed"] += 1
        d = whole_samples(dev.delay_samples)
        if sup is None:
            sup, _, _ = mp_sup(k * dev.sample_time / 2, big_b, d)
        out["ref_ms"].append((time.perf_counter() - t0) * 1e3)
        assert passivity_samples(dev)[0] == d == whole_delay_samples(dev)
        out["max_d"] = max(out["max_d"], d)
        out["fractional"] += passivity_samples(dev)[1]
        t0 = time.perf_counter()
        r = passivity_margin(dev, k, big_b)
        out["ms"].append((time.perf_counter() - t0) * 1e3)
        b = dev.damping
        scale = k * dev.sample_time / 2 * (2 * d + 1) + big_b
        slack = 4e-16 * abs(sup)          # the reference is the 32-digit sup rounded to a float
        case = (dev.model_dump(exclude_none=True), k, big_b, sup, r.required_damping, r.error_bound)
        if r.required_damping < sup - slack or r.required_damping - sup > r.error_bound + slack:
            out["bound_violations"].append(case)
        out["max_rel_err"] = max(out["max_rel_err"], (r.required_damping - sup) / scale)
        out["max_rel_bound"] = max(out["max_rel_bound"], r.error_bound / scale)
        truly = b > sup
        if r.passive and not truly or not r.passive and b > sup + r.error_bound + slack:
            out["wrong_labels"].append(case)
        elif not r.passive and truly:
            out["conservative"] += 1
        out["passive" if r.passive else "not_passive"] += 1
        if i >= n_random and big_b > 0.0:
            # the largest passive K at this B, backed off as a design is (1e-8): passive by the mpmath sup
            kp = largest_passive_stiffness(dev, big_b).stiffness
            if kp > 0.0:
                out["passive_k_checked"] += 1
                if not mp_sup(kp * (1 - 1e-8) * dev.sample_time / 2, big_b, d)[0] < b:
                    out["passive_k_unsafe"].append((*case, kp))
        if i % verify_every == 0 or i >= n_random:
            t0 = time.perf_counter()
            v = verify_passivity(dev, k, big_b, r.passive)
            out["verify_ms"].append((time.perf_counter() - t0) * 1e3)
            out["verified"] += 1
            out["verify"][v.verdict] += 1
            right = r.passive == truly
            if (v.verdict == "confirmed" and not right) or (v.verdict == "contradicted" and right) or (
                    v.verdict == "contradicted" and not r.passive and b <= r.required_damping):
                out["verify_wrong"].append((*case, v.verdict, v.reason))
    return out


def test_the_issue_example_is_not_passive_and_verify_agrees():
    dev, k, big_b = EXAMPLE
    r = passivity_margin(dev, k, big_b)
    sup, theta, _ = mp_sup(k * dev.sample_time / 2, big_b, 28)
    assert not r.passive and r.delay_samples_used == 28
    assert sup == pytest.approx(29962.7703618644, abs=1e-9) and theta == pytest.approx(0.10825, abs=1e-5)
    assert sup <= r.required_damping <= sup + r.error_bound + 4e-16 * sup
    assert r.error_bound < 1e-12 * r.required_damping
    v = verify_passivity(dev, k, big_b, r.passive)
    assert v.verdict == "confirmed" and v.label_confirmed == "not passive"
    assert verify_passivity(dev, k, big_b, True).verdict == "contradicted"


def test_the_delay_is_rounded_up_as_the_contract_says():
    """⌈t_d/T⌉: a delay 4.6e-12 samples past a whole sample counts one more (verify said the whole sample, from
    ⌈t_d/T − 1e-9⌉, and contradicted the analysis); one within 64 ulp of a whole sample is that sample."""
    t = 1e-4
    for whole in (0, 3, 28, 4820):
        for extra, want in ((4.6e-12, whole + 1), (0.0, whole), (0.5, whole + 1)):
            dev = Device(mass=1.0, damping=1.0, sample_time=t, delay=(whole + extra) * t)
            assert passivity_samples(dev)[0] == whole_delay_samples(dev) == (whole if dev.delay_samples == whole
                                                                             or abs(dev.delay_samples - whole) <= 64
                                                                             * 2.2e-16 * max(1, whole) else want)
    dev = Device(mass=1.0, damping=1.0, sample_time=0.001, delay=0.003)
    assert passivity_samples(dev)[0] == whole_delay_samples(dev) == 3


def test_a_long_delay_top_lobe_is_found():
    """4,820 samples of delay, b just below the sup (nearly equal lobes): not passive, and verify confirms that."""
    t, d = 2e-5, 4820
    k, big_b = 2 * 1e-4 / t, 50.0
    sup, _, _ = mp_sup(k * t / 2, big_b, d)
    dev = Device(mass=1.0, damping=sup * (1 - 1e-10), sample_time=t, delay=d * t)
    r = passivity_margin(dev, k, big_b)
    assert not r.passive and sup <= r.required_damping <= sup + r.error_bound + 4e-16 * sup
    assert verify_passivity(dev, k, big_b, False).label_confirmed == "not passive"
    above = dev.model_copy(update={"damping": sup * (1 + 1e-9)})
    assert passivity_margin(above, k, big_b).passive
    assert verify_passivity(above, k, big_b, True).label_confirmed == "passive"


@pytest.mark.slow
def test_passivity_labels_against_the_mpmath_sup():
    """300 walls (150 random, 150 aimed): 0 wrong labels, the bound holds, verify never wrong."""
    out = run_passivity_property(150, 150, seed=34)
    assert out["wrong_labels"] == [] and out["bound_violations"] == []
    assert out["verify_wrong"] == [] and out["passive_k_unsafe"] == []
    assert out["verify"]["confirmed"] >= 0.8 * out["verified"]
    assert out["max_rel_bound"] < 1e-10 and math.isfinite(out["max_rel_err"])
