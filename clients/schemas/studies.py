"""The service's studies answers as this client reads them (generated: see clients/schemas/__init__.py)."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import Field

from clients.schemas.answer import Answer


class StudyCreated(Answer):
    id: str
    status: str
    points: Annotated[int, Field(description="points the study will compute")]
    problem: str


class StudyResults(Answer):
    id: str
    status: str
    total: int
    offset: int
    limit: int
    next_offset: Annotated[int | None, Field(description="offset of the next page; null on the last stored row")]
    columns: Annotated[list[str], Field(description="index, the swept paths, the problem's results, error")]
    rows: list[dict[str, Any]]


class StudyStatus(Answer):
    id: str
    name: str | None
    problem: str
    status: Literal["queued", "running", "cancelling", "done", "cancelled", "failed"]
    total: Annotated[int, Field(description="points in the study")]
    done: Annotated[int, Field(description="points stored (failed ones included)")]
    failed: Annotated[int, Field(description="points whose evaluation failed (their rows carry the reason)")]
    progress: Annotated[float, Field(description="done/total")]
    rate: Annotated[float | None, Field(description="points per second in the current (or last) run")]
    eta_s: Annotated[float | None, Field(description="seconds to completion at that rate")]
    created_at: Annotated[float, Field(description="Unix time [s]")]
    started_at: Annotated[float | None, Field(description="Unix time [s] the current (or last) run started")]
    resumed_from: Annotated[int, Field(description="points already stored when the current (or last) run started")]
    finished_at: float | None
    error: str | None
    sweep: Annotated[list[str], Field(description="the swept parameter paths, in column order")]


class StudyList(Answer):
    studies: list[StudyStatus]
    offset: int
    limit: int
