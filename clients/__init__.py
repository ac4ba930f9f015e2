"""Clients of the zwidth HTTP API: typed Python clients (sync and async) and the ``zwidth`` CLI.

Public names are re-exported here; ``tests/clients/test_exports.py`` guards the list.
"""

from .calls import Call, Plot
from .client import DEFAULT_URL, AsyncZwidthClient, Retries, Timeouts, ZwidthClient
from .errors import APIError, ProtocolError, TransportError, ValidationFailed, ZwidthError

__all__ = ["ZwidthClient", "AsyncZwidthClient", "Timeouts", "Retries", "DEFAULT_URL", "Call", "Plot",
           "ZwidthError", "TransportError", "APIError", "ValidationFailed", "ProtocolError"]
