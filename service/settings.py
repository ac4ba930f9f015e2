"""Service settings from ZWIDTH_* environment variables (pydantic-settings).

Secrets have no default.  ``ZWIDTH_API_TOKEN_FILE`` (a file holding the token, as
Docker and Kubernetes secrets are mounted) is read once, when the settings are
built; the token itself is never logged nor echoed.
"""

from __future__ import annotations

from pathlib import Path

from pydantic import Field, SecretStr, field_validator, model_validator
from pydantic_settings import BaseSettings, NoDecode, SettingsConfigDict
from typing_extensions import Annotated

__all__ = ["Settings", "default_database_url", "describe_store"]


def default_database_url() -> str:
    """SQLite in the platform's user data directory (e.g. ~/.local/share/zwidth/studies.db on Linux), so a
    study store never lands in whatever directory the server happened to start from.

    With HOME unset (and no XDG_DATA_HOME) there is no user directory to use: Python would fall back to the
    password database's home (root's, in a container started with ``env -i``), so this refuses, saying why."""
    import os

    from platformdirs import user_data_path

    if os.name == "posix" and not os.environ.get("XDG_DATA_HOME") and not os.environ.get("HOME"):
        raise ValueError("database_url: HOME is unset, so the default study store (~/.local/share/zwidth/studies.db) "
                         "has no home; set HOME to a writable directory, or ZWIDTH_DATABASE_URL")

    return f"sqlite:///{user_data_path('zwidth', appauthor=False) / 'studies.db'}"


def describe_store(url: str) -> str:
    """The store's URL as it may be printed: the password hidden."""
    from sqlalchemy.engine import make_url

    try:
        return make_url(url).render_as_string(hide_password=True)
    except Exception:  # noqa: BLE001 - an unparsable URL is reported by the store itself
        return "<unparsable database URL>"


class Settings(BaseSettings):
    model_config = SettingsConfigDict(env_prefix="ZWIDTH_", extra="ignore")

    max_body_bytes: int = Field(default=1_000_000, gt=0, le=1 << 30,
                                description="largest accepted request body [bytes]; larger bodies get 413")
    body_timeout: float = Field(default=10.0, gt=0, le=3600,
                                description="time to receive a whole request body [s]; a slower body gets 408")
    api_token: SecretStr | None = Field(default=None, description="bearer token required on /v1 routes when set")
    api_token_file: Path | None = Field(default=None, description="file holding the bearer token (read at start)")
    request_timeout: float = Field(default=30.0, gt=0, le=86_400,
                                   description="compute budget of one request [s]; a bounded call past it answers 503")
    compute_workers: int = Field(default=2, ge=1, le=64,
                                 description="worker processes for expensive (bounded) numerics calls")
    compute_queue: int = Field(default=32, ge=0, le=10_000,
                               description="expensive calls that may wait for a busy worker; past them a request is "
                                           "refused at once with 503 and Retry-After (the wait counts against "
                                           "request_timeout)")
    inline_cost_ms: float = Field(default=25.0, ge=0, le=60_000,
                                  description="calls estimated below this cost [ms] run inline in the request thread "
                                              "(not bounded by the budget); 0 sends every estimated call to a worker")
    prestart_workers: bool = Field(default=True,
                                   description="start the compute workers when the app starts (else on first use)")
    cors_origins: Annotated[list[str], NoDecode] = Field(
        default_factory=list, description="allowed CORS origins, comma-separated (none by default: CORS off)")
    database_url: str = Field(default_factory=default_database_url,
                              description="study store (SQLAlchemy URL); default SQLite in the user data directory")
    dask_scheduler: str | None = Field(default=None, description="Dask scheduler address for studies")
    log_level: str = Field(default="info", description="logging level of the zwidth loggers")
    access_log: bool = Field(default=True, description="one JSON line per request on the zwidth.access logger")

    @field_validator("cors_origins", mode="before")
    @classmethod
    def _split_origins(cls, value: object) -> object:
        # "https://a.example, https://b.example" as well as a JSON list.
        if isinstance(value, str):
            text = value.strip()
            if text.startswith("["):
                import json

                return json.loads(text)
            return [o.strip() for o in text.split(",") if o.strip()]
        return value

    @model_validator(mode="after")
    def _token_from_file(self) -> "Settings":
        if self.api_token is None and self.api_token_file is not None:
            try:
                token = self.api_token_file.read_text(encoding="utf-8").strip()
            except OSError as exc:
                raise ValueError(f"api_token_file: cannot read the token file ({exc.strerror})") from None
            if not token:
                raise ValueError("api_token_file: the token file is empty")
            self.api_token = SecretStr(token)
        if self.api_token is not None and not self.api_token.get_secret_value():
            # An empty ZWIDTH_API_TOKEN would otherwise accept "Bearer " as a valid credential.
            raise ValueError("api_token: must not be empty (unset it to disable auth)")
        return self

    @property
    def token(self) -> str | None:
        return None if self.api_token is None else self.api_token.get_secret_value()

