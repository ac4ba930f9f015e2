"""Errors the numerics raise for input they refuse: :class:`InputError` (field + rule), defined in models.errors."""

from models.errors import InputError, from_validation

__all__ = ["InputError", "from_validation", "NOT_REPRESENTABLE"]

#: The rule of a refusal when double precision overflowed or divided by zero on valid input (the exception's own
#: text goes to the log only: it names numpy internals, not the request).
NOT_REPRESENTABLE = ("the parameters are outside the numerically representable range (an overflow or a division by "
                     "zero in double precision)")
