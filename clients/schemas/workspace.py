"""The service's workspace answer (POST /v1/analysis/workspace) as this client reads it (written to match
/openapi.json's WorkspaceResponse; tests/clients/test_client_schemas.py holds it there)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from clients.schemas.answer import Answer


class WorkspacePointOut(Answer):
    pose: Annotated[list[float], Field(description="joint values [rad or m]")]
    normal: Annotated[list[float], Field(description="unit wall normal in the base frame")]
    critical_stiffness: Annotated[float | None, Field(description="K_cr of the full multi-mode plant G_n [N/m]")]
    critical_frequency: Annotated[float | None, Field(description="ω [rad/s] of the binding crossover")]
    effective_mass: Annotated[float, Field(description="1/(nᵀ J M⁻¹ Jᵀ n) [kg]")]
    effective_damping: Annotated[float, Field(description="the 1-DOF approximation's b [N·s/m]")]
    one_dof_critical_stiffness: Annotated[float | None, Field(description="exact K_cr of the 1-DOF approximation")]
    one_dof_relative_error: Annotated[float | None, Field(description="one_dof / full − 1")]
    modes: Annotated[int, Field(description="modes of G_n seen along the normal")]
    reason: str | None


class WorkspaceResponse(Answer):
    points: list[WorkspacePointOut]
    worst: WorkspacePointOut
    minimum_critical_stiffness: Annotated[float | None, Field(description="the lowest K_cr [N/m]")]
    normals: Literal["given", "worst"]
    note: Annotated[str, Field(description="the model's assumptions")] = ""
    elapsed_ms: float
