"""Study results as flat rows, CSV and Parquet (columns: index, the swept paths, the results, error).

Exports stream: a first pass over the stored rows finds the columns and their types, a second
writes them in batches (Parquet: one row group per batch, sent as it is written), so a million-point study never sits in memory as Python objects.  CSV
writes floats with ``repr`` (exact round trip), booleans as ``true``/``false`` and a missing value
(a non-finite number, or a field that does not apply to the point) as an empty cell.
"""

from __future__ import annotations

import csv
import io
import json
from itertools import islice
from typing import Any, Callable, Iterable, Iterator, Sequence

__all__ = ["flat_row", "columns", "scan_columns", "csv_chunks", "parquet_chunks", "parquet_bytes", "block_columns",
           "parquet_block_chunks", "csv_block_chunks"]

Rows = Callable[[], Iterable[dict[str, Any]]]


def flat_row(paths: Sequence[str], rec: dict[str, Any]) -> dict[str, Any]:
    row: dict[str, Any] = {"index": rec["idx"]}
    row.update(zip(paths, rec["params"]))
    row.update(rec["result"] or {})
    row["error"] = rec["error"]
    return row


def columns(paths: Sequence[str], rows: Iterable[dict[str, Any]]) -> list[str]:
    return scan_columns(paths, rows)[0]


def _kind(v: Any) -> str:
    if isinstance(v, bool):
        return "bool"
    if isinstance(v, int):
        return "int"
    if isinstance(v, float):
        return "float"
    return "str"


def scan_columns(paths: Sequence[str], rows: Iterable[dict[str, Any]]) -> tuple[list[str], dict[str, set[str]]]:
    """Column order (index, swept paths, results as first seen, error) and the value kinds of each."""
    kinds: dict[str, set[str]] = {"index": {"int"}, **{p: {"float"} for p in paths}}
    for row in rows:
        for k, v in row.items():
            if k != "error" and v is not None:
                kinds.setdefault(k, set()).add(_kind(v))
            elif k != "error":
                kinds.setdefault(k, set())
    kinds["error"] = {"str"}
    return list(kinds), kinds


def _batches(rows: Iterable[dict[str, Any]], size: int) -> Iterator[list[dict[str, Any]]]:
    it = iter(rows)
    while batch := list(islice(it, size)):
        yield batch


def _cell(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    return str(value)


def csv_chunks(cols: Sequence[str], rows: Iterable[dict[str, Any]], batch: int = 5000) -> Iterator[str]:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(cols)
    for part in _batches(rows, batch):
        for row in part:
            w.writerow([_cell(row.get(c)) for c in cols])
        yield buf.getvalue()
        buf.seek(0)
        buf.truncate()
    if buf.tell():
        yield buf.getvalue()


def _arrow_type(kinds: set[str]):
    import pyarrow as pa

    if not kinds:
        return pa.null()
    if kinds == {"bool"}:
        return pa.bool_()
    if kinds == {"int"}:
        return pa.int64()
    if kinds <= {"int", "float"}:
        return pa.float64()  # a column holding 1 and 1.5 is a double column
    return pa.string()


def _convert(values: list, typ) -> list:
    import pyarrow as pa

    if typ == pa.float64():
        return [None if v is None else float(v) for v in values]
    if typ == pa.string():
        return [None if v is None else (v if isinstance(v, str) else _cell(v)) for v in values]
    return values


class _Drain(io.RawIOBase):
    """A write-only sink that hands its bytes on and keeps only their count (Parquet's offsets need tell())."""

    def __init__(self):
        super().__init__()
        self.parts: list[bytes] = []
        self.pos = 0

    def writable(self) -> bool:
        return True

    def write(self, b) -> int:
        data = bytes(b)
        self.parts.append(data)
        self.pos += len(data)
        return len(data)

    def tell(self) -> int:
        return self.pos

    def take(self) -> bytes:
        out, self.parts = b"".join(self.parts), []
        return out


def parquet_chunks(cols: Sequence[str], kinds: dict[str, set[str]], rows: Iterable[dict[str, Any]],
                   batch: int = 50_000) -> Iterator[bytes]:
    """The Parquet file in pieces: one row group per ``batch`` rows, handed on as soon as it is written, so that
    the memory held is one batch whatever the study's size (pyarrow.parquet.ParquetWriter, footer last)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    schema = pa.schema([(c, _arrow_type(kinds[c])) for c in cols])
    sink = _Drain()
    with pq.ParquetWriter(pa.PythonFile(sink, mode="w"), schema) as writer:
        for part in _batches(rows, batch):
            data = {c: pa.array(_convert([r.get(c) for r in part], schema.field(c).type), type=schema.field(c).type)
                    for c in cols}
            writer.write_table(pa.table(data, schema=schema))
            if chunk := sink.take():
                yield chunk
    if chunk := sink.take():
        yield chunk


def parquet_bytes(cols: Sequence[str], kinds: dict[str, set[str]], rows: Iterable[dict[str, Any]],
                  batch: int = 50_000) -> bytes:
    return b"".join(parquet_chunks(cols, kinds, rows, batch))


def block_columns(paths: Sequence[str], schemas: Iterable[Any]) -> tuple[list[str], dict[str, set[str]]] | None:
    """scan_columns of a study stored in blocks, from the blocks' schemas alone (their result columns' kinds):
    the same columns, order and kinds as scanning every row.  None when a result key is also the name of the
    index, a swept path or the error (the row form decides which value wins; export_rows then does it)."""
    from .blocks import result_columns

    kinds: dict[str, set[str]] = {"index": {"int"}, **{p: {"float"} for p in paths}}
    fixed = set(kinds) | {"error"}
    for schema in schemas:
        for key, seen, _ in result_columns(schema):
            if key in fixed:
                return None
            kinds.setdefault(key, set()).update(seen)
    kinds["error"] = {"str"}
    return list(kinds), kinds


def _block_table(start: int, data: bytes, cols: Sequence[str], paths: Sequence[str], schema):
    """One block as a table of the export's schema (what parquet_chunks would write for its rows)."""
    import numpy as np
    import pyarrow as pa
    import pyarrow.compute as pc

    from .blocks import read_table, result_columns

    table = read_table(data)
    n = table.num_rows
    json_keys = {key for key, _, is_json in result_columns(table.schema) if is_json}
    names = set(table.column_names)
    has = table.column("has_result").combine_chunks()
    out = {"index": pa.array(np.arange(start, start + n, dtype=np.int64))}
    for j, p in enumerate(paths):
        out[p] = table.column(f"p{j}").combine_chunks()
    for c in cols[1 + len(paths):-1]:
        typ = schema.field(c).type
        if f"r:{c}" not in names:
            out[c] = pa.nulls(n, typ)
            continue
        arr = table.column(f"r:{c}").combine_chunks()
        keep = has if f"m:{c}" not in names else pc.and_(has, table.column(f"m:{c}").combine_chunks())
        if arr.type != typ or c in json_keys:
            vals = arr.to_pylist()
            if c in json_keys:
                vals = [None if v is None else json.loads(v) for v in vals]
            arr = pa.array(_convert(vals, typ), type=typ)
        out[c] = pc.if_else(keep, arr, pa.nulls(n, typ)) if typ != pa.null() else arr
    out["error"] = table.column("error").combine_chunks()
    return pa.table(out, schema=schema)


def parquet_block_chunks(cols: Sequence[str], kinds: dict[str, set[str]], paths: Sequence[str],
                         blocks: Iterable[tuple[int, bytes]], batch: int = 50_000) -> Iterator[bytes]:
    """parquet_chunks of a study stored in blocks, column by column (no dict per row): the same file, one row
    group per ``batch`` rows or more (whole blocks), handed on as it is written."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    schema = pa.schema([(c, _arrow_type(kinds[c])) for c in cols])
    sink = _Drain()
    with pq.ParquetWriter(pa.PythonFile(sink, mode="w"), schema) as writer:
        parts, rows = [], 0
        for start, data in blocks:
            parts.append(_block_table(start, data, cols, paths, schema))
            rows += parts[-1].num_rows
            if rows >= batch:
                writer.write_table(pa.concat_tables(parts), row_group_size=rows)
                parts, rows = [], 0
                if chunk := sink.take():
                    yield chunk
        if parts:
            writer.write_table(pa.concat_tables(parts), row_group_size=rows)
    if chunk := sink.take():
        yield chunk


_SPECIAL = (",", '"', "\n", "\r")


def _csv_field(text: str) -> str:
    """``text`` as csv.writer writes it in a row of several fields (its own quoting rules, whatever the Python)."""
    if not any(c in text for c in _SPECIAL):
        return text
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerow(["", text])
    return buf.getvalue()[1:-1]


def _text_cells(values: list, kinds: set[str]) -> list[str]:
    """The CSV cells of one column's values (None: empty), exactly as csv_chunks writes them from rows."""
    if kinds == {"float"}:
        r = float.__repr__
        return ["" if v is None else r(v) for v in values]
    if kinds == {"bool"}:
        return ["" if v is None else ("true" if v else "false") for v in values]
    if kinds == {"int"}:
        return ["" if v is None else str(v) for v in values]
    return ["" if v is None else _csv_field(_cell(v)) for v in values]


def _block_csv(start: int, data: bytes, cols: Sequence[str], paths: Sequence[str]) -> str:
    """One block's rows of csv_chunks, built column by column (the same text, without a dict per row)."""
    import pyarrow.compute as pc

    from .blocks import read_table, result_columns

    table = read_table(data)
    n = table.num_rows
    if n == 0:
        return ""
    names = set(table.column_names)
    stored = {key: (kinds, is_json) for key, kinds, is_json in result_columns(table.schema)}
    has = table.column("has_result").combine_chunks()
    cells = [list(map(str, range(start, start + n)))]
    cells += [_text_cells(table.column(f"p{j}").to_pylist(), {"float"}) for j in range(len(paths))]
    for c in cols[1 + len(paths):-1]:
        if c not in stored:
            cells.append([""] * n)
            continue
        kinds, is_json = stored[c]
        arr = table.column(f"r:{c}").combine_chunks()
        keep = has if f"m:{c}" not in names else pc.and_(has, table.column(f"m:{c}").combine_chunks())
        vals = pc.if_else(keep, arr, None).to_pylist() if arr.null_count < n else [None] * n
        if is_json:
            vals = [None if v is None else json.loads(v) for v in vals]
            kinds = {_kind(v) if not isinstance(v, (list, dict)) else "json" for v in vals if v is not None}
        cells.append(_text_cells(vals, kinds if len(kinds) == 1 else {"mixed"}))
    cells.append(["" if e is None else _csv_field(e) for e in table.column("error").to_pylist()])
    return "\n".join(map(",".join, zip(*cells))) + "\n"


def csv_block_chunks(cols: Sequence[str], paths: Sequence[str], blocks: Iterable[tuple[int, bytes]]) -> Iterator[str]:
    """csv_chunks of a study stored in blocks, one block at a time and column by column: the same text (header,
    ``repr`` floats, inf and nan as Python writes them, true/false, empty cells, csv quoting), a block's memory at a
    time.  ``cols`` from block_columns (None there: the row export)."""
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerow(cols)
    yield buf.getvalue()
    for start, data in blocks:
        if text := _block_csv(start, data, cols, paths):
            yield text
