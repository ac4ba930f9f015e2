"""The one rule for non-finite numbers in answers (service/schemas/finite.py): null, at any depth."""

from __future__ import annotations

import json
import math

from pydantic import BaseModel

from service.schemas.finite import FiniteModel, FiniteOrNull, finite_or_null


class _Inner(BaseModel):
    value: float | None
    interval: list[float | None]


class _Answer(FiniteModel):
    margin: float | None
    inner: _Inner
    table: dict[str, float | None]
    one: FiniteOrNull = None


def test_finite_or_null_at_any_depth():
    data = {"a": math.inf, "b": [1.0, -math.inf, (math.nan, 2)], "c": {"d": {"e": math.nan}}, "s": "inf", "n": 3}
    assert finite_or_null(data) == {"a": None, "b": [1.0, None, [None, 2]], "c": {"d": {"e": None}}, "s": "inf",
                                    "n": 3}


def test_a_response_built_from_raw_numerics_answers_null_and_valid_json():
    a = _Answer(margin=math.inf, inner={"value": math.nan, "interval": [0.0, math.inf]},
                table={"k": -math.inf, "b": 2.5}, one=math.inf)
    text = a.model_dump_json()
    assert json.loads(text) == {"margin": None, "inner": {"value": None, "interval": [0.0, None]},
                                "table": {"k": None, "b": 2.5}, "one": None}
    assert "Infinity" not in text and "NaN" not in text


def test_the_routes_and_schemas_keep_no_private_null_helpers():
    """One rule: the helpers _finite / _finite_or_null of the routes and schemas are gone."""
    import pathlib

    root = pathlib.Path(__file__).resolve().parents[2] / "service"
    for path in [*root.glob("routes/*.py"), *root.glob("schemas/*.py")]:
        text = path.read_text()
        assert "def _finite" not in text, path
