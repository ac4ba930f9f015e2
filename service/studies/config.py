"""Settings of the study runner (ZWIDTH_STUDY_*); the store URL and the Dask scheduler are the
service's own ZWIDTH_DATABASE_URL and ZWIDTH_DASK_SCHEDULER (service.settings)."""

from __future__ import annotations

from pydantic import Field
from pydantic_settings import BaseSettings, SettingsConfigDict

__all__ = ["StudySettings"]


class StudySettings(BaseSettings):
    model_config = SettingsConfigDict(env_prefix="ZWIDTH_STUDY_", extra="ignore")

    workers: int | None = Field(default=None, ge=1, le=256,
                                description="local worker processes; default one per core")
    max_points: int = Field(default=1_000_000, ge=1, le=100_000_000,
                            description="the most points one study may have (grid product or samples); the "
                                        "results store holds them in blocks, one row per chunk")
    chunk_size: int = Field(default=64, ge=1, le=100_000,
                            description="points per task: large enough to amortise a task's overhead, small enough "
                                        "for progress and a prompt cancel (vectorised problems take up to their "
                                        "chunk_factor times this, optim.studies.problems)")
    busy_timeout: float = Field(default=5.0, gt=0, le=3600,
                                description="how long a request waits for a locked SQLite store [s] before its 503 "
                                            "(capped at the request budget ZWIDTH_REQUEST_TIMEOUT)")
    max_active: int = Field(default=100, ge=1, le=1_000_000,
                            description="studies that may be queued or running at once; past it POST /v1/studies "
                                        "answers 429 with Retry-After (a restart resumes every active study)")
    dask_direct: bool = Field(default=True,
                              description="gather a Dask task's results from its worker directly (False: through the "
                                          "scheduler, for workers the service cannot reach)")
