"""What a stiffness design must respect (all optional except the gain margin).

The one definition of these rules: the HTTP request of POST /v1/design/stiffness uses this model (the service's
``StiffnessRequirementsIn`` only adds the robust design's ``uncertainty`` and JSON-number strictness), so a bound,
a pairing rule and their messages live here alone.
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field, model_validator

from optim.errors import InputError

__all__ = ["StiffnessRequirements", "DESIGN_BACK_OFF", "LIMIT_MAX"]

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
    max_force_noise: float | None = _limit("largest damper force step F_noise [N]; needs quantization")

    @model_validator(mode="after")
    def _pairs(self) -> "StiffnessRequirements":
        for a, b, rule in _PAIRS:
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

    def damping_caps(self, sample_time: float) -> dict[str, float]:
        """Upper limits on B [N·s/m] by constraint name."""
        caps = {}
        if self.max_damping is not None:
            caps["max_damping"] = self.max_damping
        if self.quantization is not None and self.max_force_noise is not None:
            caps["max_force_noise"] = self.max_force_noise * sample_time / self.quantization
        return caps
