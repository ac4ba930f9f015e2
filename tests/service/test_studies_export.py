"""Study exports and blocks (issue 20): Parquet streams row groups in bounded memory, and a chunk's block reads
back exactly the points it was made of."""

from __future__ import annotations

import io

import numpy as np
import pyarrow.parquet as pq
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from service.studies.blocks import decode_rows, encode_block
from service.studies.export import csv_chunks, parquet_bytes, parquet_chunks, scan_columns
from service.studies.store import StudyStore


def _rows(n: int):
    for i in range(n):
        yield {"index": i, "device.delay": i * 1e-4, "critical_stiffness": None if i % 7 == 0 else 1000.0 + i,
               "stable": i % 2 == 0, "reason": None if i % 3 else "no crossover", "error": None}


def test_parquet_streams_one_row_group_per_batch():
    cols, kinds = scan_columns(["device.delay"], _rows(2500))
    consumed = []

    def counted():
        for r in _rows(2500):
            consumed.append(r["index"])
            yield r

    chunks = parquet_chunks(cols, kinds, counted(), batch=1000)
    first = next(chunks)
    assert first and len(consumed) <= 1000          # the first bytes leave before the rest is read
    data = first + b"".join(chunks)
    f = pq.ParquetFile(io.BytesIO(data))
    assert f.num_row_groups == 3
    table = f.read()
    assert table.column_names == cols and table.num_rows == 2500
    want = list(_rows(2500))
    assert table.column("critical_stiffness").to_pylist() == [r["critical_stiffness"] for r in want]
    assert table.column("stable").to_pylist() == [r["stable"] for r in want]
    assert table.column("reason").to_pylist() == [r["reason"] for r in want]
    # the pieces make the same file as the whole
    assert pq.read_table(io.BytesIO(parquet_bytes(cols, kinds, _rows(2500), batch=1000))).equals(table)


def test_csv_streams_in_batches():
    cols, _ = scan_columns(["device.delay"], _rows(30))
    parts = list(csv_chunks(cols, _rows(30), batch=10))
    assert len(parts) == 3 and "".join(parts).count("\n") == 31


def test_a_block_reads_back_exactly_what_was_evaluated(tmp_path):
    """Floats bit for bit (inf, -0.0, subnormal), ints, bools, strings, None, a key missing at some points, a
    key whose values mix int and float, and failed points, through the store and back."""
    rows = [([1.0, 2.0], {"k": 1.5, "s": "x", "b": True, "n": None, "mix": 1}, None),
            ([0.1, 3.0], None, "invalid device: mass must be > 0"),
            ([1e-300, -0.0], {"k": 2.0000000000000004, "mix": 1.5, "only": "here"}, None),
            ([5e-324, 7.0], {"k": float("inf"), "s": None, "b": False, "n": None, "mix": None, "big": 2**70}, None)]
    block = encode_block(7, [v for v, _, _ in rows], [r for _, r, _ in rows], [e for _, _, e in rows])
    assert (block.start, block.n, block.failed) == (7, 4, 1)
    back = list(decode_rows(7, block.data))
    assert [(r["idx"], r["params"], r["result"], r["error"]) for r in back] == [(7 + i, *row) for i, row in
                                                                              enumerate(rows)]
    assert all(type(a) is type(b) for r, (_, want, _) in zip(back, rows) if want
               for a, b in zip(r["result"].values(), want.values()))
    assert str(back[2]["params"][1]) == "-0.0" and list(back[3]["result"]) == list(rows[3][1])
    assert [r["idx"] for r in decode_rows(7, block.data, 1, 3)] == [8, 9]
    store = StudyStore(f"sqlite:///{tmp_path / 's.db'}")
    store.migrate()
    store.create("s", "stability", {"sweep": {}}, total=20)
    assert store.write_chunk("s", block) == 4 and store.write_chunk("s", block) == 0
    assert list(store.iter_results("s")) == back and store.results("s", 1, 2) == back[1:3]
    assert (store.get("s")["done"], store.get("s")["failed"]) == (4, 1)
    store.dispose()


def test_parquet_from_blocks_equals_parquet_from_rows():
    """The column-by-column export of blocks writes the table the row export writes: keys first seen in a later
    block, a key missing at some points, a key whose values mix int and float in one block and are ints in
    another, an all-None key, failed points."""
    from service.studies.blocks import read_schema
    from service.studies.export import block_columns, flat_row, parquet_block_chunks

    blocks = [encode_block(0, [[1.0], [2.0]], [{"k": 1.5, "mix": 1}, None], [None, "bad point"]),
              encode_block(2, [[3.0], [4.0], [5.0]],
                           [{"k": 2.0, "mix": 2.5, "late": True}, {"k": None, "none": None}, {"s": "x", "mix": 3}],
                           [None, None, None]),
              encode_block(9, [[6.0]], [{"mix": 7, "s": "y"}], [None])]
    paths = ["device.delay"]
    stored = [(b.start, b.data) for b in blocks]
    rows = [flat_row(paths, r) for start, data in stored for r in decode_rows(start, data)]
    cols, kinds = scan_columns(paths, rows)
    assert block_columns(paths, [read_schema(d) for _, d in stored]) == (cols, kinds)
    want = pq.read_table(io.BytesIO(parquet_bytes(cols, kinds, rows)))
    got = pq.read_table(io.BytesIO(b"".join(parquet_block_chunks(cols, kinds, paths, stored, batch=2))))
    assert got.equals(want) and got.to_pylist() == want.to_pylist()


def _csv_both(paths, blocks):
    """(row export, block export) CSV text of the same stored blocks."""
    from service.studies.blocks import read_schema
    from service.studies.export import block_columns, csv_block_chunks, flat_row

    stored = [(b.start, b.data) for b in blocks]
    rows = [flat_row(paths, r) for start, data in stored for r in decode_rows(start, data)]
    cols, _ = scan_columns(paths, rows)
    assert block_columns(paths, [read_schema(d) for _, d in stored])[0] == cols
    return "".join(csv_chunks(cols, iter(rows), batch=3)), "".join(csv_block_chunks(cols, paths, stored))


def test_csv_from_blocks_is_the_csv_from_rows_byte_for_byte():
    """The column-wise CSV of blocks writes the row export's text exactly: header, repr floats (nan, inf, -inf, -0.0,
    subnormal, 1e+16), true/false, empty cells for None, a missing key and a failed point, big ints, a key whose values
    mix kinds (JSON-stored: 1 and 1.5, a list), strings that need csv quoting, keys first seen in a later block."""
    nan, inf = float("nan"), float("inf")
    blocks = [encode_block(0, [[1.0, -0.0], [2.5, 5e-324]],
                           [{"k": nan, "mix": 1, "s": 'a,b "q"', "b": True}, None], [None, "bad, \"point\"\nline 2"]),
              encode_block(2, [[1e16, 0.1], [3.0, -inf], [4.0, 1e-300]],
                           [{"k": -inf, "mix": 2.5, "late": False, "big": 2**70}, {"k": None, "none": None, "s": ""},
                            {"s": "x\ry", "mix": [1, "two"], "k": inf, "b": False, "int": -3}],
                           [None, None, None]),
              encode_block(9, [[6.0, 7.0]], [{"mix": 7, "s": "é ü", "k": 0.30000000000000004}], [None])]
    old, new = _csv_both(["device.delay", "device.mass"], blocks)
    assert new == old
    assert "nan" in old and ",-inf," in old and "1e+16" in old and "-0.0" in old and "5e-324" in old   # not vacuous
    assert old.splitlines()[0] == "index,device.delay,device.mass,k,mix,s,b,late,big,none,int,error"


@pytest.mark.parametrize("problem", ["stability", "critical_stiffness"])
def test_csv_from_blocks_of_a_real_study(problem):
    """A rigid grid through the column path, with failed points (delays beyond 10,000 samples at T = 1 µs)."""
    from service.studies.blocks import evaluate_block

    rng = np.random.default_rng(4)
    values = np.column_stack([rng.uniform(0.01, 20, 90), rng.choice([0.0, 0.001, 0.05], 90),
                              rng.choice([1e-3, 1e-6], 90)])
    axes = [("device.mass", "float"), ("device.delay", "float"), ("device.sample_time", "float")]
    blocks = [evaluate_block(problem, {"mass": 5.4, "damping": 3.5}, {"stiffness": 1500.0}, axes, a, values[a:b], "h")
              for a, b in ((0, 40), (40, 41), (41, 90))]
    assert sum(b.failed for b in blocks) > 0
    old, new = _csv_both([p for p, _ in axes], blocks)
    assert new == old and old.count("\n") == 91


@settings(max_examples=60, deadline=None)
@given(st.lists(st.one_of(st.none(), st.text(max_size=6, alphabet=st.sampled_from(list('ab ,"\r\n\t;é\x00')))),
                min_size=1, max_size=8))
def test_csv_quoting_of_any_string_is_the_csv_modules(texts):
    old, new = _csv_both(["x"], [encode_block(0, [[float(i)] for i in range(len(texts))],
                                              [{"s": t} for t in texts], texts)])
    assert new == old
