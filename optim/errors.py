"""Errors the numerics raise for input they refuse: :class:`InputError` (field + rule), defined in models.errors."""

from models.errors import InputError, from_validation

__all__ = ["InputError", "from_validation"]
