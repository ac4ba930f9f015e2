"""The one exception for input that breaks a rule: it names the field and the rule (re-exported by optim.errors).

It lives at the bottom of the layering (models/) so that the device and scene validators raise it too;
optim and the service import it from ``optim.errors``.
"""

from __future__ import annotations

from pydantic import ValidationError

__all__ = ["InputError", "from_validation"]


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


def from_validation(exc: ValidationError, prefix: str = "") -> InputError:
    """The first error of a pydantic validation as one InputError located under ``prefix``: an InputError a
    validator raised keeps its field and rule (below the model it was raised in), any other error gives its
    location and pydantic's message."""
    e = exc.errors(include_url=False)[0]
    loc = [str(p) for p in e.get("loc", ())]
    cause = (e.get("ctx") or {}).get("error")
    if isinstance(cause, InputError):
        field = cause.field.split(".")
        if loc[-len(field):] != field:
            loc += field
        return InputError(prefix + ".".join(loc), cause.rule)
    return InputError(prefix + ".".join(loc) if loc else prefix.rstrip(".") or "input", e["msg"])
