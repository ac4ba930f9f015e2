"""Study results as flat rows, CSV and Parquet (columns: index, the swept paths, the results, error).

CSV writes floats with ``repr`` (exact round trip), booleans as ``true``/``false`` and a missing
value (a non-finite number or a field that does not apply) as an empty cell.
"""

from __future__ import annotations

import csv
import io
from typing import Any, Iterable, Sequence

__all__ = ["flat_row", "columns", "to_csv", "to_parquet"]


def flat_row(paths: Sequence[str], rec: dict[str, Any]) -> dict[str, Any]:
    row: dict[str, Any] = {"index": rec["idx"]}
    row.update(zip(paths, rec["params"]))
    row.update(rec["result"] or {})
    row["error"] = rec["error"]
    return row


def columns(paths: Sequence[str], rows: Iterable[dict[str, Any]]) -> list[str]:
    seen: dict[str, None] = dict.fromkeys(["index", *paths])
    for row in rows:
        seen.update(dict.fromkeys(k for k in row if k != "error"))
    return [*seen, "error"]


def _cell(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    return str(value)


def to_csv(cols: Sequence[str], rows: Iterable[dict[str, Any]]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(cols)
    for row in rows:
        w.writerow([_cell(row.get(c)) for c in cols])
    return buf.getvalue()


def to_parquet(cols: Sequence[str], rows: Sequence[dict[str, Any]]) -> bytes:
    import pyarrow as pa
    import pyarrow.parquet as pq

    data = {}
    for c in cols:
        values = [r.get(c) for r in rows]
        # An integer column that also holds floats (a swept value written as 1 and 1.5) is a double column.
        if any(isinstance(v, float) for v in values) and any(isinstance(v, int) and not isinstance(v, bool) for v in values):
            values = [float(v) if v is not None else None for v in values]
        data[c] = pa.array(values)
    buf = io.BytesIO()
    pq.write_table(pa.table(data), buf)
    return buf.getvalue()
