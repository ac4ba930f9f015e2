"""Service settings from ZWIDTH_* environment variables (pydantic-settings)."""

from __future__ import annotations

from pydantic import Field
from pydantic_settings import BaseSettings, SettingsConfigDict


class Settings(BaseSettings):
    model_config = SettingsConfigDict(env_prefix="ZWIDTH_", extra="ignore")

    max_body_bytes: int = Field(default=1_000_000, gt=0, description="largest accepted request body [bytes]")
    api_token: str | None = Field(default=None, description="bearer token required on /v1 routes when set")
    request_timeout: float = Field(default=30.0, gt=0, description="per-request compute budget [s]")
    cors_origins: list[str] = Field(default_factory=list, description="allowed CORS origins (none by default)")
    database_url: str = Field(default="sqlite:///zwidth.db", description="study store (SQLAlchemy URL)")
    dask_scheduler: str | None = Field(default=None, description="Dask scheduler address for studies")
    log_level: str = Field(default="info")
