"""Chunks evaluated as columns (optim.studies.columns) against the per-point path, bit for bit (issue 20).

The per-point path (optim.studies.problems.evaluate_chunk: a Device and a dict per point, the problem's own
row functions) is the reference; the column path must give every point exactly the same results, errors
and key order, whether the point is in a large chunk, a small one or alone.  Both are stored as blocks and
compared decoded, by repr (NaN and -0.0 included).
"""

from __future__ import annotations

import numpy as np
import pytest

from optim.studies.columns import evaluate_columns
from optim.studies.problems import evaluate_chunk
from service.studies.blocks import decode_rows, encode_block, evaluate_block

RIGID = {"mass": 5.4, "damping": 3.5, "sample_time": 0.001}
AXES = [("device.mass", "float"), ("device.damping", "float"), ("device.sample_time", "float"),
        ("device.delay", "float"), ("requirements.damping", "float"), ("requirements.stiffness", "float")]


def _points(seed: int, n: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    t = rng.choice([1e-3, 2.5e-4, 1e-6], n)
    delay = np.where(rng.random(n) < 0.5, rng.integers(0, 21, n) * t, rng.uniform(0, 0.02, n))  # some > 10⁴ T
    cols = [rng.uniform(1e-3, 50, n), np.where(rng.random(n) < 0.1, 0.0, rng.uniform(0, 20, n)), t, delay,
            np.where(rng.random(n) < 0.2, 0.0, rng.uniform(0, 3000, n)), rng.uniform(10, 1e6, n)]
    return np.column_stack(cols)


def _rows_path(problem, device, req, axes, start, values):
    out = evaluate_chunk(problem, device, req, axes, list(enumerate(values.tolist(), start)))
    return encode_block(start, values, [o[2] for o in out], [o[3] for o in out])


def _decoded(block) -> list[str]:
    return [repr(r) for r in decode_rows(block.start, block.data)]


@pytest.mark.parametrize("problem", ["critical_stiffness", "stability"])
@pytest.mark.parametrize("seed", [0, 1])
def test_columns_equal_the_per_point_path_bit_for_bit(problem, seed):
    values = _points(seed, 300)
    block = evaluate_block(problem, RIGID, {}, AXES, 40, values, "h")
    handled, _, errors = evaluate_columns(problem, RIGID, {}, AXES, values, lambda rows: [])
    # the column path took every point the device model accepts; the others (> 10,000 samples of delay) it left
    assert np.array_equal(~handled, values[:, 3] / values[:, 2] > 10_000) and handled.sum() > 200
    ref = _rows_path(problem, RIGID, {}, AXES, 40, values)
    assert block.failed == ref.failed > 0                       # > 10,000 samples of delay: those points fail
    assert _decoded(block) == _decoded(ref)
    # any chunk: a point alone, or in another chunk, has the same row
    alone = [evaluate_block(problem, RIGID, {}, AXES, 40 + i, values[i:i + 1], "h") for i in (0, 7, 123)]
    odd = evaluate_block(problem, RIGID, {}, AXES, 41, values[1:50], "h")
    rows = _decoded(ref)
    assert [_decoded(b)[0] for b in alone] == [rows[0], rows[7], rows[123]]
    assert _decoded(odd) == rows[1:50]


@pytest.mark.parametrize("problem", ["critical_stiffness", "stability"])
def test_base_requirements_and_a_grid_like_the_bench(problem):
    """No wall stiffness (no margin, no passivity), then the bench's mass × delay grid with a base wall."""
    values = _points(3, 80)[:, [0, 3]]
    axes = [AXES[0], AXES[3]]
    for req in ({}, {"damping": 2.0}, {"stiffness": 1500, "damping": 2.0}):
        block = evaluate_block(problem, RIGID, req, axes, 0, values, "h")
        assert _decoded(block) == _decoded(_rows_path(problem, RIGID, req, axes, 0, values))


def test_chunks_the_columns_do_not_take():
    """A cable device, a preset or another swept path go through the per-point path unchanged."""
    v = np.array([[0.0], [0.001]])
    assert evaluate_columns("stability", {"preset": "lhifam"}, {}, [("device.delay", "float")], v, None) is None
    assert evaluate_columns("stability", RIGID, {}, [("device.human.mass", "float")], v, None) is None
    assert evaluate_columns("stiffness", RIGID, {}, [("device.delay", "float")], v, None) is None


def test_blocks_are_compressed_and_uncompressed_blocks_still_read(monkeypatch, tmp_path):
    """New blocks are LZ4-compressed Arrow IPC; a block stored before (uncompressed) decodes, and exports, to the
    same rows and the same Parquet file: a store written by the previous version keeps reading."""
    import io

    import pyarrow.parquet as pq

    from service.studies import blocks
    from service.studies.export import block_columns, parquet_block_chunks
    from service.studies.store import StudyStore

    values = _points(5, 400)[:, [0, 3]]
    axes = [AXES[0], AXES[3]]
    new = evaluate_block("stability", RIGID, {"stiffness": 1500.0}, axes, 0, values, "h")
    monkeypatch.setattr(blocks, "COMPRESSION", None)
    old = evaluate_block("stability", RIGID, {"stiffness": 1500.0}, axes, 400, values, "h")
    monkeypatch.undo()

    assert len(new.data) < 0.7 * len(old.data)                   # the floats of a grid compress about 2×
    rows_new, rows_old = _decoded(new), _decoded(old)             # the same points, at indices 0… and 400…
    assert [r[r.index("'params'"):] for r in rows_new] == [r[r.index("'params'"):] for r in rows_old]
    # both kinds side by side in one store: results and Parquet read across them
    store = StudyStore(f"sqlite:///{tmp_path}/s.db")
    store.migrate()
    store.create("s", "stability", {}, 800)
    assert store.write_chunk("s", new) == 400 and store.write_chunk("s", old._replace(digest="o")) == 400
    got = store.results("s", 390, 20)
    assert [r["idx"] for r in got] == list(range(390, 410))
    assert repr(got[10:]) == repr(list(decode_rows(400, old.data, 0, 10)))
    paths = ["device.mass", "device.delay"]
    cols, kinds = block_columns(paths, [blocks.read_schema(d) for _, d in store.iter_blocks("s")])
    pq_bytes = b"".join(parquet_block_chunks(cols, kinds, paths, store.iter_blocks("s")))
    table = pq.read_table(io.BytesIO(pq_bytes))
    assert table.num_rows == 800
    assert table.slice(0, 400).drop(["index"]).equals(table.slice(400, 400).drop(["index"]))
    store.dispose()


def test_a_task_planning_its_own_values_makes_the_coordinators_block():
    """evaluate_planned (a Dask task given the scattered plan and a place) makes the block evaluate_block makes from
    the values the coordinator planned: the same bytes, and the content hash the runner checks it by."""
    from optim.studies.problems import plan_study
    from service.studies.blocks import block_hash, evaluate_planned

    plan = plan_study("critical_stiffness", RIGID, {"stiffness": 1500.0},
                      {"device.mass": {"start": 0.5, "stop": 10.0, "num": 37}, "device.delay": [0.0, 0.001, 0.02]})
    axes = [(a.path, a.kind) for a in plan.axes]
    for start, n in ((0, 1), (5, 40), (100, 11)):
        values = plan.values(start, start + n)
        mine = evaluate_planned(plan, start, n)
        theirs = evaluate_block(plan.problem, plan.device, plan.requirements, axes, start, values,
                                block_hash(start, values))
        assert (mine.start, mine.n, mine.failed, mine.digest, mine.data) == theirs[:5]


@pytest.mark.parametrize("problem", ["critical_stiffness", "stability"])
def test_a_chunk_evaluated_in_parts_is_the_chunk_evaluated_whole(problem, monkeypatch):
    """A Dask task's chunk is evaluated in parts of COLUMN_PART points (blocks._columns_in_parts): the same block,
    bit for bit, as the chunk evaluated whole, with failed points and points left to the per-point path in parts."""
    from service.studies import blocks

    values = _points(7, 300)
    whole = evaluate_block(problem, RIGID, {}, AXES, 11, values, "h")
    monkeypatch.setattr(blocks, "COLUMN_PART", 37)
    parts = evaluate_block(problem, RIGID, {}, AXES, 11, values, "h")
    assert whole.failed == parts.failed > 0
    assert _decoded(parts) == _decoded(whole)
    assert parts.data == whole.data


CABLE_AXES = [("device.cable.stiffness", "float"), ("device.delay", "float"), ("device.cable.damping", "float"),
              ("requirements.stiffness", "float"), ("requirements.damping", "float")]


def _cable_points(seed: int, n: int) -> np.ndarray:
    """Grid-like cable points (each cable at several delays, as a study chunk has them) with some the model or the
    wall's rules refuse: a negative delay, > 10,000 samples of delay, a wall K of 0, a negative wall B."""
    rng = np.random.default_rng(seed)
    cables = np.column_stack([rng.uniform(2e4, 1.2e5, n // 6 + 1), rng.uniform(0.5, 30.0, n // 6 + 1)])
    pick = np.repeat(np.arange(len(cables)), 6)[:n]
    delay = np.where(rng.random(n) < 0.7, rng.integers(0, 21, n) * 1e-3, rng.uniform(0, 0.02, n))
    delay[rng.random(n) < 0.03] = -1e-3
    delay[rng.random(n) < 0.03] = 11.0
    k = np.where(rng.random(n) < 0.05, 0.0, rng.uniform(100.0, 2e5, n))
    b = np.where(rng.random(n) < 0.2, 0.0, rng.uniform(0.0, 400.0, n))
    b[rng.random(n) < 0.03] = -1.0
    return np.column_stack([cables[pick, 0], delay, cables[pick, 1], k, b])


@pytest.mark.parametrize("seed", [0, 1])
def test_cable_columns_equal_the_per_point_path_bit_for_bit(seed):
    """Issue 32: a damped cable grid's critical_stiffness chunk as columns (optim.studies.cable_columns) has every
    point's row of the per-point path, refused points' errors included, in any chunk."""
    base = {"preset": "lhifam"}
    values = _cable_points(seed, 120)
    handled, _, _ = evaluate_columns("critical_stiffness", base, {}, CABLE_AXES, values, None)
    bad = (values[:, 1] < 0) | (values[:, 1] > 10.0) | (values[:, 3] <= 0) | (values[:, 4] < 0)
    assert np.array_equal(handled, ~bad) and handled.sum() > 80
    block = evaluate_block("critical_stiffness", base, {}, CABLE_AXES, 3, values, "h")
    ref = _rows_path("critical_stiffness", base, {}, CABLE_AXES, 3, values)
    assert block.failed == ref.failed >= bad.sum() > 0
    rows = _decoded(ref)
    assert _decoded(block) == rows
    # kcr 0 (B ≥ B_max), finite values, and the margin are all among the rows compared
    assert any("'critical_stiffness': 0.0" in r for r in rows) and any("gain_margin_db': -" in r for r in rows)
    alone = [evaluate_block("critical_stiffness", base, {}, CABLE_AXES, 3 + i, values[i:i + 1], "h") for i in (0, 5, 77)]
    assert [_decoded(b)[0] for b in alone] == [rows[0], rows[5], rows[77]]
    assert _decoded(evaluate_block("critical_stiffness", base, {}, CABLE_AXES, 4, values[1:40], "h")) == rows[1:40]


def test_cable_columns_with_base_requirements_and_the_bench_grid():
    """The bench's grid (cable stiffness × whole delays × cable damping, the wall in the base requirements) and a
    cable block given whole (no preset), against the per-point path; stability and undamped cables are not taken."""
    from bench.bench_studies import cable_study
    from optim.studies.problems import plan_study
    from service.studies.blocks import evaluate_planned

    req = cable_study("critical_stiffness", 1_000_000)
    plan = plan_study(req["problem"], req["base"]["device"], req["base"]["requirements"], req["sweep"])
    axes = [(a.path, a.kind) for a in plan.axes]
    for start, n in ((0, 130), (500_017, 60)):
        values = plan.values(start, start + n)
        block = evaluate_planned(plan, start, n)
        assert _decoded(block) == _decoded(_rows_path(plan.problem, plan.device, plan.requirements, axes, start,
                                                      values))
    from models.device import Device
    cable = Device(preset="lhifam").model_dump(exclude={"preset"})
    values = _cable_points(2, 36)[:, :3]
    for req in ({}, {"damping": 2.0}, {"stiffness": 1500, "damping": 2.0}):
        block = evaluate_block("critical_stiffness", cable, req, CABLE_AXES[:3], 0, values, "h")
        assert _decoded(block) == _decoded(_rows_path("critical_stiffness", cable, req, CABLE_AXES[:3], 0, values))
    assert evaluate_columns("stability", cable, {}, CABLE_AXES[:3], values, None) is None
    # an undamped cable point (no damping anywhere) is left to the per-point path
    undamped = dict(cable, damping=0.0, cable=dict(cable["cable"], motor_damping=0.0, body_damping=0.0))
    got = evaluate_columns("critical_stiffness", undamped, {}, [("device.cable.damping", "float")],
                           np.array([[0.0], [1.0]]), None)
    assert got is not None and got[0].tolist() == [False, True]
