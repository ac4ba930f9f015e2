"""Response pieces of the accuracy ladder shared by the design endpoints (issue 6)."""

from __future__ import annotations

from dataclasses import asdict
from typing import Literal

from pydantic import BaseModel, Field

from optim.stability.analysis import DEFAULT_GRID_POINTS, GridPoints, Method

from .finite import finite_or_null

__all__ = ["Method", "GridPoints", "MethodField", "GridPointsField", "ExactCheckOut", "rung_fields", "DesignStatus",
           "DesignStatusField"]

# Method and GridPoints (the rung and its bounds) are optim.stability.analysis's: one rule, one message.


def MethodField():  # noqa: N802  (a Field factory, used like a type in the request models)
    return Field(default="exact", description="rung of the accuracy ladder: linear (closed form), grid (dense scan on "
                                              "a frequency grid), exact, reference (exact design re-verified at 40 digits)")


#: status of a stiffness or inertia design (optim.stiffness.StiffnessDesign, optim.transparency.InertiaDesign)
DesignStatus = Literal["optimal", "infeasible", "failed", "unsafe"]


def DesignStatusField():  # noqa: N802
    return Field(description="optimal; infeasible or failed (reason says why); unsafe: the design of an approximate "
                             "rung (method linear or grid) fails its own exact check (reason and exact_check give the "
                             "exact margin)")


def GridPointsField():  # noqa: N802
    return Field(default=DEFAULT_GRID_POINTS, description="frequency samples for method=grid")


class ExactCheckOut(BaseModel):
    """The exact analysis of a design produced by an approximate rung (linear, grid)."""

    critical_value: float | None = Field(description="exact K_cr(B) [N/m] (stiffness) or K_f,cr at the cutoff (inertia)")
    gain_margin_db: float | None = Field(description="exact margin of the design [dB]")
    meets_min_gain_margin: bool
    stable: bool
    passive: bool | None = Field(None, description="exact delayed passivity (when passivity was required)")
    statement: str = Field(description="'safe: …' or 'UNSAFE: …'")


def rung_fields(info) -> dict:
    """method, error_estimate, error_source, exact_check of an optim.design_ladder.RungInfo, JSON-safe."""
    check = asdict(info.exact_check) if info.exact_check is not None else None
    return finite_or_null({"method": info.method, "error_estimate": info.error_estimate,
                           "error_source": info.error_source, "exact_check": check})
