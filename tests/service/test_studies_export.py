"""Study exports and the encoded write path (issue 20): Parquet streams row groups in bounded memory, and a
chunk encoded in the worker reads back exactly as one encoded by the store."""

from __future__ import annotations

import io

import pyarrow.parquet as pq

from service.studies.encode import encode_rows
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


def test_encoded_and_plain_chunks_read_back_the_same(tmp_path):
    store = StudyStore(f"sqlite:///{tmp_path / 's.db'}")
    store.migrate()
    for sid in ("plain", "encoded"):
        store.create(sid, "stability", {"sweep": {}}, total=4)
    rows = [(0, "a" * 32, [1.0, 2.0], {"k": 1.5, "s": "x", "b": True, "n": None}, None),
            (1, "b" * 32, [0.1, 3.0], None, "invalid device: mass must be > 0"),
            (2, "c" * 32, [1e-300, -0.0], {"k": 2.0000000000000004}, None)]
    assert store.write_chunk("plain", rows) == 3
    assert store.write_chunk("encoded", encode_rows(rows)) == 3
    assert store.write_chunk("encoded", encode_rows(rows[:2])) == 0      # a chunk that ran twice adds nothing
    got = {sid: list(store.iter_results(sid)) for sid in ("plain", "encoded")}
    assert got["plain"] == got["encoded"]
    assert [(r["params"], r["result"], r["error"]) for r in got["encoded"]] == [(p, res, e) for _, _, p, res, e in rows]
    assert (store.get("encoded")["done"], store.get("encoded")["failed"]) == (3, 1)
    store.dispose()
