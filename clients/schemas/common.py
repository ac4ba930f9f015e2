"""The service's common answers as this client reads them (generated: see clients/schemas/__init__.py)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from clients.schemas.answer import Answer


class CrossoverOut(Answer):
    frequency: Annotated[float, Field(description="ω [rad/s]")]
    stiffness: Annotated[float, Field(description="K [N/m] that puts a closed-loop pole at e^{jωT}")]


class HumanOut(Answer):
    mass: Annotated[float, Field(description="m_h [kg]")]
    damping: Annotated[float, Field(description="b_h [N·s/m]")]
    stiffness: Annotated[float, Field(description="k_h [N/m]")]


class PassivityVerificationOut(Answer):
    verdict: Annotated[
        Literal["confirmed", "contradicted", "not_checkable"],
        Field(
            description=(
                "whether `label` holds: b against the condition's sup, decided by verify's own proof (a 40-digit"
                " witness above b, or every interval of its own grid bounded below b)"
            )
        ),
    ]
    required_damping: Annotated[
        float | None,
        Field(
            description=(
                "the delayed Colgate–Schenkel condition recomputed from its complex form: the largest value met"
                " [N·s/m]"
            )
        ),
    ]
    physical_damping: Annotated[float, Field(description="b [N·s/m]")]
    reason: str | None
    label: Annotated[Literal["passive", "not passive"], Field(description="the label checked: the answer's `passive`")]
    label_confirmed: Annotated[
        Literal["passive", "not passive"] | None,
        Field(
            description=(
                "the label this record confirms (`label` when the verdict is confirmed, else null): a confirmed"
                " `not passive` is not a passive wall"
            )
        ),
    ]


class PointVerificationOut(Answer):
    device: Annotated[
        dict[str, float], Field(description="the uncertain parameters' values at this device (path → value, SI)")
    ]
    kind: Annotated[
        Literal["corner", "worst", "least passive", "interior"],
        Field(description="a corner of the box, the worst device the design found, its least passive device, or the worst "
                    "device of verify's own interior search (closed-loop eigenvalues at g·K)"),
    ]
    critical_gain: Annotated[
        float | None,
        Field(
            description=(
                "K_cr(B) [N/m] (stiffness) or K_f,cr at the design's cutoff (inertia) of this device by the exact"
                " analysis; null: every gain is stable"
            )
        ),
    ]
    gain_margin_db: Annotated[float | None, Field(description="20·log10(critical_gain / designed gain) [dB]")]
    verdict: Annotated[
        Literal["confirmed", "contradicted", "not_checkable"],
        Field(
            description=(
                "this device: its critical gain, the designed gain (and passivity) on the closed loop, and its"
                " margin ≥ the required one"
            )
        ),
    ]
    method: str | None
    reason: str | None


class VerificationOut(Answer):
    verdict: Annotated[
        Literal["confirmed", "contradicted", "not_checkable"],
        Field(
            description=(
                "confirmed: stable below and unstable above the answer; contradicted: the closed loop says otherwise"
                " (never silent); not_checkable: the reason says why"
            )
        ),
    ]
    method: Annotated[
        str | None, Field(description="eigenvalues of the closed-loop state matrix, or the argument principle")
    ]
    epsilon: Annotated[float | None, Field(description="relative step ε of the two checked gains")]
    gain_below: Annotated[float | None, Field(description="gain checked below the answer, K_cr·(1 − ε) [N/m]")]
    gain_above: Annotated[float | None, Field(description="gain checked above the answer, K_cr·(1 + ε) [N/m]")]
    radius_below: Annotated[
        float | None, Field(description="closed-loop spectral radius at gain_below (eigenvalue method)")
    ]
    radius_above: Annotated[
        float | None, Field(description="closed-loop spectral radius at gain_above (eigenvalue method)")
    ]
    unstable_poles_below: Annotated[
        int | None, Field(description="poles outside the unit circle at gain_below (argument principle)")
    ]
    unstable_poles_above: Annotated[
        int | None, Field(description="poles outside the unit circle at gain_above (argument principle)")
    ]
    design_radius: Annotated[
        float | None, Field(description="spectral radius at the wall itself (designs, or a given controller)")
    ] = None
    design_unstable_poles: Annotated[
        int | None, Field(description="poles outside the unit circle at the wall itself")
    ] = None
    passivity: Annotated[
        PassivityVerificationOut | None, Field(description="independent check of a passivity label")
    ] = None
    points: Annotated[
        list[PointVerificationOut] | None,
        Field(
            description=(
                "robust designs (requirements.uncertainty): one verdict per checked device of the box (every corner"
                " and the worst device found); the verdict above is the worst of them"
            )
        ),
    ] = None
    label: Annotated[
        str | None,
        Field(
            description=(
                "what the record checks, in the answer's words: the critical gain (or the design's margin), and the"
                " wall's own labels (stable, passive or not passive) when the answer gives them"
            )
        ),
    ] = None
    label_confirmed: Annotated[
        str | None,
        Field(description="`label` when the verdict is confirmed, else null: what was confirmed, explicitly"),
    ] = None
    elapsed_ms: Annotated[float, Field(description="time the verification took [ms]")]
    reason: str | None
