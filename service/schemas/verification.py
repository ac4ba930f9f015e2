"""The ``verification`` record of an answer asked with ``verify: true`` (optim.verification)."""

from __future__ import annotations

from dataclasses import asdict
from typing import Literal

from pydantic import BaseModel, Field

from .finite import finite_or_null

__all__ = ["VerificationOut", "VerifyField", "verification_out"]


def VerifyField():
    return Field(default=False, strict=True,
                 description="add `verification`: the closed loop at the critical gain ·(1 ∓ ε) by a method "
                             "independent of the answer (closed-loop eigenvalues or an argument-principle count)")


class PassivityVerificationOut(BaseModel):
    verdict: Literal["confirmed", "contradicted", "not_checkable"] = Field(
        description="whether `label` holds: b against the condition's sup, decided by verify's own proof (a "
                    "40-digit witness above b, or every interval of its own grid bounded below b)")
    required_damping: float | None = Field(description="the delayed Colgate–Schenkel condition recomputed from its "
                                                       "complex form: the largest value met [N·s/m]")
    physical_damping: float = Field(description="b [N·s/m]")
    reason: str | None
    label: Literal["passive", "not passive"] = Field(description="the label checked: the answer's `passive`")
    label_confirmed: Literal["passive", "not passive"] | None = Field(
        description="the label this record confirms (`label` when the verdict is confirmed, else null): a confirmed "
                    "`not passive` is not a passive wall")


class PointVerificationOut(BaseModel):
    device: dict[str, float] = Field(description="the uncertain parameters' values at this device (path → value, SI)")
    kind: Literal["corner", "worst", "least passive", "interior"] = Field(
        description="a corner of the box, the worst device the design found, its least passive device, or the worst "
                    "device of verify's own interior search (closed-loop eigenvalues at g·K)")
    critical_gain: float | None = Field(description="K_cr(B) [N/m] (stiffness) or K_f,cr at the design's cutoff "
                                                    "(inertia) of this device by the exact analysis; null: every "
                                                    "gain is stable")
    gain_margin_db: float | None = Field(description="20·log10(critical_gain / designed gain) [dB]")
    verdict: Literal["confirmed", "contradicted", "not_checkable"] = Field(
        description="this device: its critical gain, the designed gain (and passivity) on the closed loop, and "
                    "its margin ≥ the required one")
    method: str | None
    reason: str | None


class VerificationOut(BaseModel):
    verdict: Literal["confirmed", "contradicted", "not_checkable"] = Field(
        description="confirmed: stable below and unstable above the answer; contradicted: the closed loop says "
                    "otherwise (never silent); not_checkable: the reason says why")
    method: str | None = Field(description="eigenvalues of the closed-loop state matrix, or the argument principle")
    epsilon: float | None = Field(description="relative step ε of the two checked gains")
    gain_below: float | None = Field(description="gain checked below the answer, K_cr·(1 − ε) [N/m]")
    gain_above: float | None = Field(description="gain checked above the answer, K_cr·(1 + ε) [N/m]")
    radius_below: float | None = Field(description="closed-loop spectral radius at gain_below (eigenvalue method)")
    radius_above: float | None = Field(description="closed-loop spectral radius at gain_above (eigenvalue method)")
    unstable_poles_below: int | None = Field(description="poles outside the unit circle at gain_below (argument principle)")
    unstable_poles_above: int | None = Field(description="poles outside the unit circle at gain_above (argument principle)")
    design_radius: float | None = Field(None, description="spectral radius at the wall itself (designs, or a given controller)")
    design_unstable_poles: int | None = Field(None, description="poles outside the unit circle at the wall itself")
    passivity: PassivityVerificationOut | None = Field(None, description="independent check of a passivity label")
    points: list[PointVerificationOut] | None = Field(
        None, description="robust designs (requirements.uncertainty): one verdict per checked device of the box "
                          "(every corner and the worst device found); the verdict above is the worst of them")
    label: str | None = Field(None, description="what the record checks, in the answer's words: the critical gain "
                                                 "(or the design's margin), and the wall's own labels (stable, passive "
                                                 "or not passive) when the answer gives them")
    label_confirmed: str | None = Field(None, description="`label` when the verdict is confirmed, else null: what "
                                                          "was confirmed, explicitly")
    elapsed_ms: float = Field(description="time the verification took [ms]")
    reason: str | None


def verification_out(v) -> dict:
    """An optim.verification.Verification as JSON-safe data (no inf/NaN)."""
    return finite_or_null(asdict(v))
