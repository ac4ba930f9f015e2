"""JSON has no inf or NaN: the one rule that turns a non-finite number of an answer into null.

A number that is not finite (K_cr = inf when every K is stable, a margin of inf dB, an undefined frequency)
answers null, and the field's description or a ``reason`` beside it says why.  Every response model that
carries the numerics' floats derives from :class:`FiniteModel`, which applies the rule to everything it is
built from (nested blocks included), so a route hands over the numerics' values as they are.
"""

from __future__ import annotations

import math
from typing import Annotated, Any

from pydantic import BaseModel, BeforeValidator, model_validator

__all__ = ["finite_or_null", "FiniteOrNull", "FiniteModel"]


def finite_or_null(value: Any) -> Any:
    """``value`` with every non-finite float (at any depth of dicts, lists and tuples) replaced by None."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: finite_or_null(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite_or_null(v) for v in value]
    return value


#: A float field that answers null where the number is not finite.
FiniteOrNull = Annotated[float | None, BeforeValidator(finite_or_null)]


class FiniteModel(BaseModel):
    """A response whose non-finite numbers, at any depth, answer null (the JSON schema is unchanged)."""

    @model_validator(mode="before")
    @classmethod
    def _nulls(cls, data: Any) -> Any:
        return finite_or_null(data)
