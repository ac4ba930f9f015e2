"""Chunks encoded where they are computed: a worker returns its rows with params and results already as
JSON text, so the coordinator (one process, the store's only writer) does not spend its time encoding.

The text is what ``sa.JSON`` stores on SQLite (``json.dumps`` with its defaults) and reads back with
``json.loads``: a study written either way reads back the same.
"""

from __future__ import annotations

import json
from typing import Any, Sequence

from optim.studies.problems import evaluate_chunk

__all__ = ["EncodedRows", "dumps", "encode_rows", "evaluate_encoded"]

dumps = json.JSONEncoder().encode


class EncodedRows(list):
    """(index, hash, params JSON text, result JSON text, error) rows of one chunk."""


def encode_rows(rows: Sequence[tuple]) -> EncodedRows:
    return EncodedRows((index, digest, dumps(params), dumps(result), error)
                       for index, digest, params, result, error in rows)


def evaluate_encoded(problem: str, device: dict[str, Any], requirements: dict[str, Any],
                     axes: Sequence[tuple[str, str]], rows: Sequence[tuple]) -> EncodedRows:
    """``optim.studies.problems.evaluate_chunk``, its rows encoded (runs in a worker: computes, never writes)."""
    return encode_rows(evaluate_chunk(problem, device, requirements, axes, rows))
