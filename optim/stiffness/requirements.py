"""What a stiffness design must respect (all optional except the gain margin).

The one definition of these rules: the HTTP request of POST /v1/design/stiffness uses this model (the service's
``StiffnessRequirementsIn`` only adds the robust design's ``uncertainty`` and JSON-number strictness), so a bound,
a pairing rule and their messages live here alone.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal, Union

from pydantic import BaseModel, ConfigDict, Discriminator, Field, Tag, model_validator

from models.velocity_filter import BackwardDifference, LowPass, MovingAverage, TransferFunctionFilter
from optim.errors import InputError

__all__ = ["StiffnessRequirements", "CutoffDesign", "DesignFilter", "DESIGN_BACK_OFF", "LIMIT_MAX",
           "DEFAULT_MAX_CUTOFF", "DEFAULT_CUTOFF_SPAN"]

#: A design sits strictly inside the limits the analysis checks: K ≤ (1 − DESIGN_BACK_OFF)·g·K_cr(B) and
#: K ≤ (1 − DESIGN_BACK_OFF)·sup passive K(B); a cap on K (max_stiffness, max_force) is met as K ≤ cap.
#: At the limit itself the project's own analysis disagrees with the label (K = K_cr is not stable at
#: min_gain_margin_db = 0; b equals the required damping to 1 ulp and is not passive, the passive set being
#: strict).  1e-8 (8.7e-8 dB of margin, far below any engineering meaning) is far above the exact analysis'
#: 1e-12 and 10⁴× verify's tolerance on its independent passivity requirement (optim.verification.PASSIVITY_RTOL
#: = 1e-12, itself 500× that recomputation's rounding bound), so that verify decides every design on its
#: passivity constraint (1e-9 equalled verify's former 1e-9 tolerance: 62 of 300 designs were not checkable);
#: at 0 dB the closed loop at K is 1e-8 inside the boundary, which the eigenvalue/argument checks resolve.
DESIGN_BACK_OFF = 1e-8

#: Largest value of any optional limit (SI): keeps every derived number representable; the device-relative
#: range of each cap is optim.domain's.
LIMIT_MAX = 1e12

#: Limits that come in pairs: (a, b, the constraint they make together).
_PAIRS = (("max_force", "max_penetration", "K·x ≤ F"), ("quantization", "max_force_noise", "B·q/T ≤ F_noise"))

#: A designed cutoff's default range: max_cutoff_hz = DEFAULT_MAX_CUTOFF/T (0.8 of the Nyquist frequency),
#: min_cutoff_hz = max/DEFAULT_CUTOFF_SPAN.
DEFAULT_MAX_CUTOFF = 0.4
DEFAULT_CUTOFF_SPAN = 1000.0
#: A designed cutoff is at least this many times the sample rate (optim.stiffness.cutoff_problem.NU_MIN).
MIN_CUTOFF_NU = 1e-5


class CutoffDesign(BaseModel):
    """A low-pass velocity filter whose cutoff the design chooses together with K and B (ARCHITECTURE.md,
    "The rendered virtual environment")."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)
    kind: Literal["low_pass"]
    design: Literal[True] = Field(description="true: the cutoff is designed (a fixed filter leaves this out)")
    order: Literal[1, 2] = Field(default=1, description="1 (first order, step-invariant) or 2 (Butterworth)")
    min_cutoff_hz: float | None = Field(default=None, gt=0, le=1e12, description="lowest cutoff [Hz]; default "
                                        f"max_cutoff_hz/{DEFAULT_CUTOFF_SPAN:g}")
    max_cutoff_hz: float | None = Field(default=None, gt=0, le=1e12, description="highest cutoff [Hz], below the "
                                        f"Nyquist frequency 1/(2T); default {DEFAULT_MAX_CUTOFF:g}/T")

    @model_validator(mode="after")
    def _range(self) -> "CutoffDesign":
        if self.min_cutoff_hz is not None and self.max_cutoff_hz is not None and \
                not self.min_cutoff_hz < self.max_cutoff_hz:
            raise InputError("max_cutoff_hz", f"the cutoff range is empty: max_cutoff_hz "
                             f"{self.max_cutoff_hz:g} must exceed min_cutoff_hz {self.min_cutoff_hz:g}")
        return self

    def band(self, sample_time: float) -> tuple[float, float]:
        """(lowest, highest) cutoff [Hz] at the sample time T; InputError naming the field for a cutoff at or above
        the Nyquist frequency or an empty range."""
        nyquist = 0.5 / sample_time
        hi = self.max_cutoff_hz if self.max_cutoff_hz is not None else DEFAULT_MAX_CUTOFF / sample_time
        lo = self.min_cutoff_hz if self.min_cutoff_hz is not None else hi / DEFAULT_CUTOFF_SPAN
        if not hi < nyquist:
            raise InputError("velocity_filter.max_cutoff_hz", f"must be below the Nyquist frequency 1/(2T) = "
                                                              f"{nyquist:.6g} Hz")
        if not lo < nyquist:
            raise InputError("velocity_filter.min_cutoff_hz", f"must be below the Nyquist frequency 1/(2T) = "
                                                              f"{nyquist:.6g} Hz")
        if not lo < hi:
            raise InputError("velocity_filter.max_cutoff_hz", f"the cutoff range is empty: max_cutoff_hz {hi:g} must "
                                                              f"exceed min_cutoff_hz {lo:g}")
        if not lo * sample_time >= MIN_CUTOFF_NU:
            raise InputError("velocity_filter.min_cutoff_hz", f"must be at least {MIN_CUTOFF_NU:g}/T = "
                                                              f"{MIN_CUTOFF_NU / sample_time:.3g} Hz")
        return lo, hi


def _filter_tag(v: Any) -> str:
    if isinstance(v, dict):
        return "design" if "design" in v else str(v.get("kind", ""))
    return "design" if isinstance(v, CutoffDesign) else str(getattr(v, "kind", ""))


#: requirements.velocity_filter: a fixed filter (any kind) or a low-pass whose cutoff is designed.
DesignFilter = Annotated[Union[Annotated[CutoffDesign, Tag("design")],
                               Annotated[BackwardDifference, Tag("backward_difference")],
                               Annotated[LowPass, Tag("low_pass")], Annotated[MovingAverage, Tag("moving_average")],
                               Annotated[TransferFunctionFilter, Tag("transfer_function")]],
                         Discriminator(_filter_tag)]


def _limit(description: str):
    return Field(default=None, gt=0, le=LIMIT_MAX, description=description)


class StiffnessRequirements(BaseModel):
    """Every limit but the gain margin is optional and acts only when given."""

    # Lax for internal callers (as models.device.Device); the service validates JSON numbers strictly.
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)

    min_gain_margin_db: float = Field(default=6.0, ge=0, le=120, description="gain margin on stiffness [dB], "
                                                                             "20·log10(K_cr/K)")
    passivity: bool = Field(default=False, description="require passivity (delayed Colgate–Schenkel form; a fractional "
                                                       "delay is rounded up to the next whole sample)")
    passive_with_quantization: bool = Field(
        default=False, description="require passivity with the device's encoder and Coulomb friction too: K ≤ 2f_c/q beside "
                           "the delayed linear condition (Abbott & Okamura 2005; needs passivity and "
                           "device.encoder_resolution; covered by the theorem only at B = 0, no delay, rigid)")
    max_damping: float | None = _limit("B ≤ max_damping [N·s/m]")
    max_stiffness: float | None = _limit("K ≤ max_stiffness [N/m]")
    max_force: float | None = _limit("actuator saturation F [N]; needs max_penetration (K·x ≤ F)")
    max_penetration: float | None = _limit("penetration x [m] at which the force must not saturate; needs max_force")
    quantization: float | None = _limit("encoder quantisation q [m]; needs max_force_noise (B·q/T ≤ F_noise)")
    max_force_noise: float | None = _limit("largest damper force step F_noise [N]; needs quantization "
                                           "(B·q·max|s_k| ≤ F_noise, B·q/T for the backward difference)")
    max_force_noise_rms: float | None = _limit("largest damper force noise [N rms] of the encoder's quantisation "
                                               "noise through the velocity filter, B·q·sqrt(Σh_k²/12); needs "
                                               "quantization")
    velocity_filter: DesignFilter | None = Field(
        default=None, description="the velocity the damper sees: a fixed filter (as controller.velocity_filter), or "
                                  "{kind: low_pass, order, design: true, min_cutoff_hz, max_cutoff_hz} to choose the "
                                  "cutoff with K and B; null: the backward difference")

    @model_validator(mode="after")
    def _pairs(self) -> "StiffnessRequirements":
        if self.max_force_noise_rms is not None and self.quantization is None:
            raise InputError("quantization", "required when max_force_noise_rms is given (B·q·sqrt(Σh²/12) ≤ F_rms)")
        for a, b, rule in _PAIRS:
            if a == "quantization" and self.max_force_noise_rms is not None:
                continue                       # quantization with an rms limit alone is a complete noise rule
            if (getattr(self, a) is None) != (getattr(self, b) is None):
                missing, other = (b, a) if getattr(self, b) is None else (a, b)
                raise InputError(missing, f"required when {other} is given ({rule})")
        return self

    @model_validator(mode="after")
    def _quantised_passivity_needs_passivity(self) -> "StiffnessRequirements":
        if self.passive_with_quantization and not self.passivity:
            raise InputError("passive_with_quantization", "needs passivity: true (the bound's linear term 2b/T is "
                             "the passivity requirement)")
        return self

    def quantization_caps(self, encoder_resolution: float | None, coulomb_friction: float | None) -> dict[str, float]:
        """K ≤ 2f_c/q [N/m] when passive_with_quantization (Abbott & Okamura 2005); refused without an encoder."""
        if not self.passive_with_quantization:
            return {}
        if encoder_resolution is None:
            raise InputError("requirements.passive_with_quantization", "needs device.encoder_resolution (q of K ≤ 2f_c/q)")
        return {"passive_with_quantization": 2 * (coulomb_friction or 0.0) / encoder_resolution}

    @property
    def gain_factor(self) -> float:
        """g = 10^(−GM/20): K ≤ g·K_cr(B)."""
        return 10.0 ** (-self.min_gain_margin_db / 20.0)

    def stiffness_caps(self) -> dict[str, float]:
        """Upper limits on K [N/m] by constraint name."""
        caps = {}
        if self.max_stiffness is not None:
            caps["max_stiffness"] = self.max_stiffness
        if self.max_force is not None and self.max_penetration is not None:
            caps["max_force"] = self.max_force / self.max_penetration
        return caps

    @property
    def designs_cutoff(self) -> bool:
        return isinstance(self.velocity_filter, CutoffDesign)

    def damping_caps(self, sample_time: float, step_peak: float | None = None,
                     noise_gain: float | None = None) -> dict[str, float]:
        """Upper limits on B [N·s/m] by constraint name.  ``step_peak`` = max|s_k| and ``noise_gain`` =
        sqrt(Σh_k²) [1/s] of the velocity filter (models.velocity_noise); None: the backward difference's 1/T and
        √2/T."""
        caps = {}
        if self.max_damping is not None:
            caps["max_damping"] = self.max_damping
        if self.quantization is not None and self.max_force_noise is not None:
            caps["max_force_noise"] = (self.max_force_noise * sample_time / self.quantization if step_peak is None
                                       else self.max_force_noise / (self.quantization * step_peak))
        if self.quantization is not None and self.max_force_noise_rms is not None:
            gain = math.sqrt(2.0) / sample_time if noise_gain is None else noise_gain
            caps["max_force_noise_rms"] = self.max_force_noise_rms * math.sqrt(12.0) / (self.quantization * gain)
        return caps
