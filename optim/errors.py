"""Errors the numerics raise for input they refuse: :class:`InputError` (field + rule), defined in models.errors."""

from models.errors import InputError

__all__ = ["InputError"]
