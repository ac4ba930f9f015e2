"""The one exception for input that breaks a rule: it names the field and the rule (re-exported by optim.errors).

It lives at the bottom of the layering (models/) so that the device and scene validators raise it too;
optim and the service import it from ``optim.errors``.
"""

from __future__ import annotations

__all__ = ["InputError"]


class InputError(ValueError):
    """Input that breaks a rule only the numerics know.

    ``field`` is the dotted location of the input relative to the object the raising function was
    given (``"delay"``, ``"requirements.humans.0.mass"``); the caller that knows the request prefixes it
    (:meth:`under`).  ``rule`` says what the value must satisfy.  A ValueError, so that code catching
    ValueError keeps working; ``str()`` is ``"field: rule"`` for logs only, never to be parsed.
    """

    def __init__(self, field: str, rule: str):
        super().__init__(f"{field}: {rule}")
        self.field = field
        self.rule = rule

    def under(self, prefix: str) -> "InputError":
        """The same error located under ``prefix`` (e.g. ``"device."``)."""
        return InputError(prefix + self.field, self.rule)

    def __reduce__(self):
        # Raised in a compute worker, it travels back pickled: rebuild it from its two parts.
        return (InputError, (self.field, self.rule))
