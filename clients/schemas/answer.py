"""The base of every answer model of the client (the generator's ``--base-class``)."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict


class Answer(BaseModel):
    """An answer of the service as this client reads it: a field the server adds later is kept (and shown by
    ``--json``), not refused, so that an older client reads a newer server's answers."""

    model_config = ConfigDict(extra="allow")
