"""Schemas of /v1/studies: batch design-space studies (issue 8)."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, Field

from optim.studies.problems import MAX_STUDY_POINTS

from .common import LHIFAM_RIGID, STRICT

__all__ = ["RangeSpec", "Sampling", "StudyBase", "StudyRequest", "StudyCreated", "StudyStatus", "StudyList",
           "StudyResults"]


class RangeSpec(BaseModel):
    """``num`` values from ``start`` to ``stop`` (ends included); a Latin hypercube samples the range."""

    model_config = STRICT
    start: float
    stop: float
    num: int | None = Field(default=None, ge=1, le=MAX_STUDY_POINTS, description="values on a grid")
    scale: Literal["linear", "log"] = "linear"


ValueList = Annotated[list[float], Field(min_length=1, max_length=MAX_STUDY_POINTS)]


class Sampling(BaseModel):
    model_config = STRICT
    design: Literal["grid", "latin_hypercube"] = Field(
        default="grid", description="Cartesian grid of the sweep, or a Latin hypercube (scipy.stats.qmc)")
    samples: int | None = Field(default=None, ge=1, le=MAX_STUDY_POINTS, description="points of a Latin hypercube")
    seed: int | None = Field(default=None, ge=0, lt=2**63,
                             description="Latin hypercube seed; drawn and stored when omitted")


class StudyBase(BaseModel):
    model_config = STRICT
    device: dict[str, Any] = Field(description="a device object (ARCHITECTURE.md), swept paths override it")
    requirements: dict[str, Any] = Field(
        default_factory=dict,
        description="stability, critical_stiffness: {stiffness?, damping?} of the wall; stiffness/inertia: the design's requirements")
    controller: dict[str, Any] | None = Field(
        default=None,
        description="stability, critical_stiffness: the wall's rendering {mass? [kg], velocity_filter?} "
                    "(ARCHITECTURE.md, 'The rendered virtual environment'); swept as controller.mass, "
                    "controller.velocity_filter.cutoff_hz (and .order, .samples)")


class StudyRequest(BaseModel):
    model_config = {**STRICT, "json_schema_extra": {"examples": [
        {"problem": "stability", "base": {"device": LHIFAM_RIGID, "requirements": {"stiffness": 2000}},
         "sweep": {"device.delay": {"start": 0, "stop": 0.003, "num": 31}, "requirements.damping": [0, 5, 10]}},
        {"problem": "stability", "base": {"device": {"preset": "lhifam"}},
         "sweep": {"device.cable.stiffness": {"start": 2e4, "stop": 2e5, "scale": "log"},
                   "device.delay": {"start": 0, "stop": 0.002}},
         "sampling": {"design": "latin_hypercube", "samples": 500, "seed": 1}},
        {"problem": "stability", "base": {"device": LHIFAM_RIGID, "requirements": {"stiffness": 2000, "damping": 20},
                                          "controller": {"velocity_filter": {"kind": "low_pass", "cutoff_hz": 50}}},
         "sweep": {"controller.velocity_filter.cutoff_hz": {"start": 5, "stop": 400, "num": 20, "scale": "log"},
                   "controller.mass": [-1, 0, 1]}}]}}
    problem: Literal["stability", "critical_stiffness", "stiffness", "inertia", "workspace_critical_stiffness"]
    base: StudyBase
    sweep: dict[str, ValueList | RangeSpec] = Field(
        description="dotted path (device.delay, device.cable.stiffness, requirements.damping, controller.mass, "
                    "controller.velocity_filter.cutoff_hz, …) -> "
                    f"values or a range; at most {MAX_STUDY_POINTS} points per study")
    sampling: Sampling = Field(default_factory=Sampling)
    name: str | None = Field(default=None, max_length=200, description="a label for listings")


class StudyCreated(BaseModel):
    id: str
    status: str
    points: int = Field(description="points the study will compute")
    problem: str


class StudyStatus(BaseModel):
    id: str
    name: str | None
    problem: str
    status: Literal["queued", "running", "cancelling", "done", "cancelled", "failed"]
    total: int = Field(description="points in the study")
    done: int = Field(description="points stored (failed ones included)")
    failed: int = Field(description="points whose evaluation failed (their rows carry the reason)")
    progress: float = Field(description="done/total")
    rate: float | None = Field(description="points per second in the current (or last) run")
    eta_s: float | None = Field(description="seconds to completion at that rate")
    created_at: float = Field(description="Unix time [s]")
    started_at: float | None = Field(description="Unix time [s] the current (or last) run started")
    resumed_from: int = Field(description="points already stored when the current (or last) run started")
    finished_at: float | None
    error: str | None
    sweep: list[str] = Field(description="the swept parameter paths, in column order")


class StudyList(BaseModel):
    studies: list[StudyStatus]
    offset: int
    limit: int


class StudyResults(BaseModel):
    id: str
    status: str
    total: int
    offset: int
    limit: int
    next_offset: int | None = Field(description="offset of the next page; null on the last stored row")
    columns: list[str] = Field(description="index, the swept paths, the problem's results, error")
    rows: list[dict[str, Any]]
