"""Schemas of POST /v1/analysis/workspace (multi-DOF devices)."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, Field, model_validator

from models.device import MAX_DELAY_SAMPLES
from models.kinematics import KINEMATIC_PRESETS, MAX_URDF_CHARS
from optim.workspace.workspace import GRAVITY_NOTE, MAX_EVALUATIONS

from .common import STRICT, RenderedController
from .finite import FiniteModel

_JOINTS = 64


class Kinematics(BaseModel):
    model_config = STRICT
    preset: Literal[tuple(KINEMATIC_PRESETS)] | None = Field(  # type: ignore[valid-type]
        default=None, description="a built-in arm (its URDF and end effector); other fields override it")
    urdf: str | None = Field(default=None, max_length=MAX_URDF_CHARS,
                             description="the device's URDF text (parsed by Pinocchio; no DOCTYPE or entities)")
    end_effector: str | None = Field(default=None, max_length=200, description="the frame the wall acts on")
    armature: list[float] | None = Field(default=None, max_length=_JOINTS,
                                         description="rotor inertia reflected to each joint [kg·m² or kg]")
    joint_damping: list[float] | None = Field(
        default=None, max_length=_JOINTS,
        description="damping of each joint [N·m·s/rad or N·s/m]; default the URDF's <dynamics damping>")


class WorkspaceDevice(BaseModel):
    model_config = STRICT
    sample_time: float = Field(default=0.001, ge=1e-7, le=1.0, description="T, sample period [s]")
    delay: float = Field(default=0.0, ge=0, le=1e4, description="t_d, total loop delay [s]")
    kinematics: Kinematics

    @model_validator(mode="after")
    def _cost(self) -> "WorkspaceDevice":
        if self.delay / self.sample_time > MAX_DELAY_SAMPLES:
            raise ValueError(f"delay is {self.delay / self.sample_time:.6g} samples; the limit is "
                             f"{MAX_DELAY_SAMPLES} samples (delay / sample_time)")
        return self


class GridPoses(BaseModel):
    model_config = STRICT
    num: int = Field(ge=1, le=MAX_EVALUATIONS, description="values per joint over its limits (num^dof poses)")


class LatinHypercube(BaseModel):
    model_config = STRICT
    samples: int = Field(ge=1, le=MAX_EVALUATIONS)
    seed: int = Field(default=0, ge=0, le=2**32 - 1)


class Poses(BaseModel):
    model_config = STRICT
    explicit: list[list[float]] | None = Field(default=None, max_length=MAX_EVALUATIONS,
                                               description="poses [rad or m per joint]")
    grid: GridPoses | None = None
    latin_hypercube: LatinHypercube | None = None

    @model_validator(mode="after")
    def _one(self) -> "Poses":
        if sum(x is not None for x in (self.explicit, self.grid, self.latin_hypercube)) != 1:
            raise ValueError("give exactly one of explicit, grid, latin_hypercube")
        return self


class WorkspaceRequest(BaseModel):
    model_config = {**STRICT, "json_schema_extra": {"examples": [
        {"device": {"sample_time": 0.001, "delay": 0.001, "kinematics": {"preset": "planar-2link"}},
         "poses": {"explicit": [[0.3, 1.0]]}, "normals": [[0, 1, 0], [1, 0, 0]]},
        {"device": {"sample_time": 0.001, "kinematics": {"preset": "planar-2link"}},
         "poses": {"latin_hypercube": {"samples": 20, "seed": 1}}, "normals": [[0.0, 1.0, 0.0]]}]}}
    device: WorkspaceDevice
    controller: RenderedController | None = Field(
        default=None, description="B [N·s/m] of the wall, its velocity filter and virtual mass (its K is not used)")
    poses: Poses
    normals: list[list[float]] | Literal["worst"] = Field(
        description="unit wall normals in the base frame (normalised), or \"worst\": each pose's worst normal")


class WorkspacePointOut(FiniteModel):
    pose: list[float] = Field(description="joint values [rad or m]")
    normal: list[float] = Field(description="unit wall normal in the base frame")
    critical_stiffness: float | None = Field(description="K_cr of the full multi-mode plant G_n [N/m]; null: every K")
    critical_frequency: float | None = Field(description="ω [rad/s] of the binding crossover")
    effective_mass: float = Field(description="1/(nᵀ J M⁻¹ Jᵀ n) [kg]")
    effective_damping: float = Field(description="m_e²·nᵀ J M⁻¹ D M⁻¹ Jᵀ n [N·s/m] (the 1-DOF approximation's b)")
    one_dof_critical_stiffness: float | None = Field(description="exact K_cr of the 1-DOF approximation [N/m]")
    one_dof_relative_error: float | None = Field(description="one_dof_critical_stiffness / critical_stiffness − 1")
    modes: int = Field(description="modes of G_n seen along the normal")
    reason: str | None


class WorkspaceResponse(FiniteModel):
    points: list[WorkspacePointOut]
    worst: WorkspacePointOut
    minimum_critical_stiffness: float | None = Field(description="the lowest K_cr over every point [N/m]")
    normals: Literal["given", "worst"]
    note: str = Field(default=GRAVITY_NOTE, description="the model's assumptions")
    elapsed_ms: float
