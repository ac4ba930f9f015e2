"""A chunk of a study's results as one compact binary block (issue 20): what a worker returns and the store keeps.

A block covers the points start … start + n − 1 of a study's plan, in order.  It is an Arrow IPC stream of one
record batch with columns in this order:

* ``p0``, ``p1``, … the swept values of each point (float64, one column per swept path, in the sweep's order);
* ``has_result`` (bool): the point has a result dict (a failed point has none);
* ``error`` (string, null when the point succeeded);
* ``r:<key>`` for every result key in first-seen order over the block's points, typed by what the values are:
  bool, int64, float64 (inf and NaN kept), string, null (every value None) or, when a key's values mix
  kinds (1 and 1.5), their JSON text (field metadata ``json``).  Field metadata ``kinds`` lists the Python
  kinds seen (bool, int, float, str), which is what an export needs to type its column without reading
  the values;
* ``m:<key>`` (bool), only when some point with a result lacks ``key``: which points have it.

Decoding gives back exactly the (params, result, error) of each point as they were evaluated: every float
bit for bit, a missing key missing and a None value None.  The content hash of a block is that of its
place and swept values (``block_hash``): a resumed study recomputes only what is missing or stale.
"""

from __future__ import annotations

import hashlib
import json
import time
from typing import Any, Iterator, NamedTuple, Sequence

import numpy as np

__all__ = ["Block", "block_hash", "encode_block", "encode_columns", "decode_rows", "read_table", "read_schema",
           "schema_kinds", "result_columns", "evaluate_block", "evaluate_planned"]

_INT64 = (-(2**63), 2**63 - 1)


class Block(NamedTuple):
    """One chunk's results: plain data a process pool pickles cheaply."""

    start: int
    """the chunk's first point (its index in the plan)."""
    n: int
    """points in the chunk (start … start + n − 1)."""
    failed: int
    """points whose evaluation failed."""
    digest: str
    """content hash of the points (block_hash)."""
    data: bytes
    """the Arrow IPC stream."""
    seconds: float = 0.0
    """the worker's time for the chunk [s] (not stored: the runner sizes the next chunks from it)."""


def block_hash(start: int, values: np.ndarray) -> str:
    """Content hash of the points start … start + len(values) − 1: their place and swept values (float64 bytes,
    exact).  The study's base is fixed by its stored request, so the place and values name the block's work."""
    arr = np.ascontiguousarray(values, dtype="<f8")
    head = f"{int(start)}:{arr.shape[0]}:{arr.shape[1] if arr.ndim == 2 else 0}|".encode()
    return hashlib.blake2b(head + arr.tobytes(), digest_size=16).hexdigest()


def _kind(v: Any) -> str | None:
    if v is None:
        return None
    if isinstance(v, (bool, np.bool_)):
        return "bool"
    if isinstance(v, (int, np.integer)):
        return "int"
    if isinstance(v, (float, np.floating)):
        return "float"
    if isinstance(v, str):
        return "str"
    return "json"


def _kinds(values: list) -> set[str]:
    """The kinds (_kind) of a column's values, None left out: one value of each Python type looked at."""
    return {k for k in map(_kind, dict(zip(map(type, values), values)).values()) if k is not None}


#: a column whose values are all of these Python types: arrow's type for it (no per-value conversion needed)
_PLAIN = {frozenset({bool}): lambda: _pa().bool_(), frozenset({bool, type(None)}): lambda: _pa().bool_(),
          frozenset({float}): lambda: _pa().float64(), frozenset({float, type(None)}): lambda: _pa().float64()}


def _pa():
    import pyarrow as pa

    return pa


def _column(values: list, kinds: set[str]):
    """(arrow array, field metadata) of one result key's values (None where a point lacks it)."""
    import pyarrow as pa

    meta = {b"kinds": ",".join(sorted(kinds)).encode()}
    if not kinds:
        return pa.nulls(len(values)), meta
    plain = _PLAIN.get(frozenset(map(type, values)))
    if plain is not None:     # Python bools or floats (and None) only: arrow takes the list as it is
        return pa.array(values, plain()), meta
    if kinds == {"bool"}:
        return pa.array([None if v is None else bool(v) for v in values], pa.bool_()), meta
    if kinds == {"int"} and all(v is None or _INT64[0] <= v <= _INT64[1] for v in values):
        return pa.array([None if v is None else int(v) for v in values], pa.int64()), meta
    if kinds == {"float"}:
        return pa.array([None if v is None else float(v) for v in values], pa.float64()), meta
    if kinds == {"str"}:
        return pa.array(values, pa.string()), meta
    meta[b"json"] = b"1"
    return pa.array([None if v is None else json.dumps(v) for v in values], pa.string()), meta


def encode_block(start: int, values: np.ndarray, results: Sequence[dict | None], errors: Sequence[str | None],
                 digest: str | None = None) -> Block:
    """The block of points start … start + n − 1 from their swept ``values`` (n × axes), results and errors."""
    import pyarrow as pa

    values = np.asarray(values, dtype=float).reshape(len(results), -1)
    n = len(results)
    cols: dict[str, list] = {}
    for i, res in enumerate(results):
        if res:
            for key, v in res.items():
                col = cols.get(key)
                if col is None:
                    col = cols[key] = [None] * n
                col[i] = v
    arrays = [pa.array(values[:, j], pa.float64()) for j in range(values.shape[1])]
    fields = [pa.field(f"p{j}", pa.float64()) for j in range(values.shape[1])]
    has = [bool(r is not None) for r in results]
    arrays += [pa.array(has, pa.bool_()), pa.array(list(errors), pa.string())]
    fields += [pa.field("has_result", pa.bool_()), pa.field("error", pa.string())]
    # every result with every key (the usual case: a problem's rows have the same keys): no presence column to make
    full = all(len(r) == len(cols) for r in results if r)
    for key, col in cols.items():
        kinds = _kinds(col)
        arr, meta = _column(col, kinds)
        arrays.append(arr)
        fields.append(pa.field(f"r:{key}", arr.type, metadata=meta))
        if full:
            continue
        present = [bool(r) and key in r for r in results]
        if any(r and not p for r, p in zip(results, present)):
            arrays.append(pa.array(present, pa.bool_()))
            fields.append(pa.field(f"m:{key}", pa.bool_()))
    data = _stream(pa.RecordBatch.from_arrays(arrays, schema=pa.schema(fields)))
    failed = sum(e is not None for e in errors)
    return Block(int(start), n, failed, digest or block_hash(start, values), data)


#: Arrow IPC buffer compression of new blocks.  LZ4 frames halve a rigid study's blocks (critical_stiffness 16,384
#: points: 991 → 535 kB, stability 1,652 → 670 kB) for ~0.4 ms per block written and ~0.3 ms read, against ~47 ms
#: of evaluation; zstd saves another 8 % for 2-4 × the time.  A reader needs nothing: the IPC stream says how each
#: buffer is compressed, and blocks stored uncompressed (before this) read as they are.
COMPRESSION = "lz4"


def _stream(batch) -> bytes:
    """One record batch as an Arrow IPC stream (buffers compressed with COMPRESSION)."""
    import pyarrow as pa

    sink = pa.BufferOutputStream()
    with pa.ipc.new_stream(sink, batch.schema, options=pa.ipc.IpcWriteOptions(compression=COMPRESSION)) as writer:
        writer.write_batch(batch)
    return sink.getvalue().to_pybytes()


def read_table(data: bytes):
    """The block's Arrow table (zero copy over ``data`` when its buffers are not compressed)."""
    import pyarrow as pa

    return pa.ipc.open_stream(pa.py_buffer(data)).read_all()


def read_schema(data: bytes):
    import pyarrow as pa

    return pa.ipc.open_stream(pa.py_buffer(data)).schema


def result_columns(schema) -> list[tuple[str, set[str], bool]]:
    """(result key, kinds, stored as JSON text) of a block's result columns, in first-seen order."""
    out = []
    for f in schema:
        if f.name.startswith("r:"):
            meta = f.metadata or {}
            kinds = set(filter(None, meta.get(b"kinds", b"").decode().split(",")))
            out.append((f.name[2:], kinds, meta.get(b"json") == b"1"))
    return out


def schema_kinds(schema) -> dict[str, set[str]]:
    return {key: kinds for key, kinds, _ in result_columns(schema)}


def _pylist(col, is_json: bool) -> list:
    vals = col.to_pylist()
    return [None if v is None else json.loads(v) for v in vals] if is_json else vals


def decode_rows(start: int, data: bytes, lo: int = 0, hi: int | None = None) -> Iterator[dict[str, Any]]:
    """Points lo … hi − 1 of the block (relative to its start) as {idx, params, result, error}: the store's row
    form, with exactly the values the worker computed."""
    table = read_table(data)
    hi = table.num_rows if hi is None else min(hi, table.num_rows)
    if hi <= lo:
        return
    part = table.slice(lo, hi - lo)
    names = part.column_names
    n_params = sum(1 for c in names if c[0] == "p" and c[1:].isdigit())
    params = [part.column(f"p{j}").to_pylist() for j in range(n_params)]
    has = part.column("has_result").to_pylist()
    errors = part.column("error").to_pylist()
    results = []
    for key, _, is_json in result_columns(part.schema):
        mask = part.column(f"m:{key}").to_pylist() if f"m:{key}" in names else None
        results.append((key, _pylist(part.column(f"r:{key}"), is_json), mask))
    for i in range(hi - lo):
        res = None
        if has[i]:
            res = {key: vals[i] for key, vals, mask in results if mask is None or mask[i]}
        yield {"idx": start + lo + i, "params": [p[i] for p in params], "result": res, "error": errors[i]}


def encode_columns(start: int, values: np.ndarray, has_result: np.ndarray, columns: dict[str, tuple[Any, Any]],
                   errors: Sequence[str | None], digest: str | None = None) -> Block:
    """The block of a chunk evaluated as columns (optim.studies.columns): key -> (values, valid) with values a
    float64/bool array or a list; a point's value counts where it has a result and is valid.  The same block,
    once decoded, as encode_block of the same points as dicts."""
    import pyarrow as pa

    values = np.asarray(values, dtype=float).reshape(len(has_result), -1)
    has = np.asarray(has_result, bool)
    arrays = [pa.array(values[:, j], pa.float64()) for j in range(values.shape[1])]
    fields = [pa.field(f"p{j}", pa.float64()) for j in range(values.shape[1])]
    arrays += [pa.array(has, pa.bool_()), pa.array(list(errors), pa.string())]
    fields += [pa.field("has_result", pa.bool_()), pa.field("error", pa.string())]
    for key, (vals, valid) in columns.items():
        ok = has if valid is None else has & np.asarray(valid, bool)
        if isinstance(vals, list):
            col = [v if o else None for v, o in zip(vals, ok.tolist())]
            kinds = _kinds(col)
            arr, meta = _column(col, kinds)
        elif not ok.any():
            arr, meta = pa.nulls(len(has)), {b"kinds": b""}
        else:
            typ = pa.bool_() if vals.dtype == bool else pa.float64()
            arr = pa.array(vals, typ, mask=~ok)
            meta = {b"kinds": b"bool" if vals.dtype == bool else b"float"}
        arrays.append(arr)
        fields.append(pa.field(f"r:{key}", arr.type, metadata=meta))
    data = _stream(pa.RecordBatch.from_arrays(arrays, schema=pa.schema(fields)))
    failed = sum(e is not None for e in errors)
    return Block(int(start), len(has), failed, digest or block_hash(start, values), data)


def evaluate_block(problem: str, device: dict[str, Any], requirements: dict[str, Any],
                   axes: Sequence[tuple[str, str]], start: int, values: np.ndarray, digest: str | None) -> Block:
    """Evaluate points start … start + n − 1 (their swept ``values``) and return their block.

    Runs in a worker (local process or Dask): computes, never writes; a task run twice returns the same block.
    A chunk the column path takes (optim.studies.columns: rigid analyses) never makes a dict per point; the
    points it refuses, and every other chunk, go through optim.studies.problems.evaluate_chunk."""
    t0 = time.perf_counter()
    block = _evaluate(problem, device, requirements, axes, start, np.asarray(values, dtype=float), digest)
    return block._replace(seconds=time.perf_counter() - t0)


def evaluate_planned(plan, start: int, n: int) -> Block:
    """evaluate_block of the plan's points start … start + n − 1, their swept values made here from the plan (a
    grid's are its axes' values by index); the block's content hash is this worker's, so the coordinator's check of
    it (runner) holds the worker to the points the coordinator planned."""
    values = plan.values(start, start + n)
    return evaluate_block(plan.problem, dict(plan.device), dict(plan.requirements),
                          [(a.path, a.kind) for a in plan.axes], start, values, None)


#: The column path evaluates a chunk in parts of at most this many points and joins their columns: a Dask task's
#: chunk (2-4 × the local one) then costs what the local chunks cost per point (a rigid critical_stiffness chunk
#: of 65,536 points evaluated whole: 3.15 µs a point, in parts of 32,768: 2.78).  Rows are independent, so the
#: parts change no bit of any row (tests/service/test_studies_blocks.py).
COLUMN_PART = 32_768


def _shape(columns) -> list:
    """What parts must share to be joined: each column's key and kind (a list, or an array's dtype)."""
    return [(key, "list" if isinstance(v, list) else np.asarray(v).dtype.str) for key, (v, _) in columns.items()]


def _columns_in_parts(problem, device, requirements, axes, values, make_devices):
    """evaluate_columns of the chunk, in parts of COLUMN_PART points joined; the whole chunk at once when a part
    is refused or the parts' columns differ in their keys (as evaluate_columns alone would decide)."""
    from optim.studies.columns import evaluate_columns

    n = len(values)
    if n <= COLUMN_PART:
        return evaluate_columns(problem, device, requirements, axes, values, make_devices)
    parts = []
    for lo in range(0, n, COLUMN_PART):
        got = evaluate_columns(problem, device, requirements, axes, values[lo:lo + COLUMN_PART],
                               lambda rows, lo=lo: make_devices([lo + int(i) for i in rows]))
        if got is None or (parts and _shape(got[1]) != _shape(parts[0][1])):
            return evaluate_columns(problem, device, requirements, axes, values, make_devices)
        parts.append(got)
    handled = np.concatenate([p[0] for p in parts])
    columns = {}
    for key in parts[0][1]:
        vals = [p[1][key][0] for p in parts]
        valid = [p[1][key][1] for p in parts]
        joined = [v for part in vals for v in part] if isinstance(vals[0], list) else np.concatenate(vals)
        ok = None if all(v is None for v in valid) else np.concatenate(
            [np.ones(len(p[0]), bool) if v is None else np.asarray(v, bool) for p, v in zip(parts, valid)])
        columns[key] = (joined, ok)
    return handled, columns, [e for p in parts for e in p[2]]


def _evaluate(problem, device, requirements, axes, start, values, digest) -> Block:
    from models.device import Device
    from optim.studies.problems import evaluate_chunk, point_builder

    build = point_builder(device, requirements, axes)

    def make_devices(rows):
        return [Device.model_validate(build(values[i].tolist())[0]) for i in rows]

    got = _columns_in_parts(problem, device, requirements, axes, values, make_devices)
    if got is not None:
        handled, columns, errors = got
        left = np.flatnonzero(~handled).tolist()
        if left:
            out = evaluate_chunk(problem, device, requirements, axes, [(start + i, values[i].tolist()) for i in left])
            if all(o[2] is None for o in out):      # refused points fail with the per-point path's words
                for i, o in zip(left, out):
                    errors[i] = o[3]
            else:
                got = None   # a rule here stricter than the model's: the whole chunk takes the per-point path
        if got is not None:
            has = handled & np.array([e is None for e in errors], bool)
            return encode_columns(start, values, has, columns, errors, digest)
    out = evaluate_chunk(problem, device, requirements, axes, list(enumerate(values.tolist(), start)))
    return encode_block(start, values, [o[2] for o in out], [o[3] for o in out], digest)
