"""bench/rigid_minimal.py (issue 32's floor for the batch rigid K_cr) agrees with zwidth's batch, and the benchmark's
section renders (a small version, so neither can rot)."""

import numpy as np

from bench import bench_core, bench_studies
from bench.rigid_minimal import minimal_rigid_batch
from models.device import Device
from optim.robust.batch import rigid_critical_stiffness


def test_minimal_batch_agrees_with_zwidth_to_1e_12():
    rng = np.random.default_rng(4)
    n = 300
    m = 10 ** rng.uniform(-3, 1, n)
    ds = np.where(np.arange(n) % 2 == 1, rng.integers(0, 21, n).astype(float), rng.uniform(0, 20, n))
    b = 10 ** rng.uniform(-4, 0.5, n) * m / 1e-3          # δ ≥ 1e-4: below it the minimal's own rounding shows
    t, td = np.full(n, 1e-3), ds * 1e-3

    def devices(rows):
        return [Device(mass=m[i], damping=b[i], delay=td[i]) for i in rows]

    bmax = rigid_critical_stiffness(m, b, t, td, np.zeros(n), devices).max_stable_damping
    bv = np.where(np.arange(n) % 3 == 0, 0.0, rng.uniform(0, 0.99, n) * bmax)
    z = rigid_critical_stiffness(m, b, t, td, bv, devices)
    k, bm = minimal_rigid_batch(m, b, t, td, bv)
    np.testing.assert_allclose(k, z.critical_stiffness, rtol=1e-12, atol=0)
    np.testing.assert_allclose(bm, z.max_stable_damping, rtol=1e-12, atol=0)
    # a wall at or past B_max: both say 0
    k0, _ = minimal_rigid_batch(m[:3], b[:3], t[:3], td[:3], 1.5 * bmax[:3])
    assert np.all(k0 == 0.0)


def test_rigid_minimal_section_renders_and_replaces_itself():
    rows = bench_core.measure_rigid_minimal(sizes=(50,), repeats=2)
    assert rows[0].beyond == 0 and rows[0].k_worst <= 1e-12
    section = bench_core.render_rigid_minimal(rows, (1.0, 2.0))
    assert "| 50 |" in section and "ratio zwidth/minimal" in section
    doc = bench_core._with_section("# head\n\nold text\n", section, bench_core.RIGID_MIN_BEGIN, bench_core.RIGID_MIN_END)
    again = bench_core._with_section(doc, section, bench_core.RIGID_MIN_BEGIN, bench_core.RIGID_MIN_END)
    assert doc == again and doc.count(bench_core.RIGID_MIN_BEGIN) == 1


def test_fractional_study_grid_and_http_table():
    study = bench_studies.fractional_study("critical_stiffness", 4000)
    assert len(study["sweep"]["device.mass"]) == 400 and study["sweep"]["device.delay"]["num"] == 10
    row = bench_studies.HttpRow("critical_stiffness", "local pool, 2 workers", 4000, 1.0, 0, 100.0, 200.0, 16384,
                                0.5, "fractional")
    whole = bench_studies.HttpRow("critical_stiffness", "local pool, 2 workers", 4000, 1.0, 0, 100.0, 200.0, 16384,
                                  0.4, "whole")
    text = bench_studies.render_http([whole, row])
    assert "| critical_stiffness | fractional | local pool, 2 workers | 4000 |" in text
    assert "the fractional grid at 0.80 × the whole grid's points per CPU-s" in text
