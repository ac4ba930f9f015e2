"""Response models the service has no schema module for yet (kept to the contract's field names)."""

from __future__ import annotations

from pydantic import BaseModel, Field

__all__ = ["Health"]


class Health(BaseModel):
    """``GET /healthz`` (ARCHITECTURE.md: ``{"status": "ok", "version": …}``)."""

    status: str = Field(description="'ok' when the service answers")
    version: str = Field(description="zwidth version")
