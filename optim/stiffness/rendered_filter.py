"""What a rendered stiffness design rendered: its velocity filter (given or designed), virtual mass and noise."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["RenderedFilter"]


@dataclass(frozen=True)
class RenderedFilter:
    """The velocity filter and virtual mass of a rendered design, with the noise it lets through."""

    kind: str
    cutoff_hz: float | None
    """f [Hz] of a low-pass (designed or given)."""
    order: int | None
    designed: bool
    """true when the design chose the cutoff."""
    min_cutoff_hz: float | None = None
    """the designed cutoff's range [Hz]."""
    max_cutoff_hz: float | None = None
    mass: float = 0.0
    """virtual mass M [kg]."""
    step_peak: float = 0.0
    """max_k |s_k| [1/s]: the velocity estimate's largest response to a unit position step."""
    noise_gain: float = 0.0
    """sqrt(Σh_k²) [1/s]: the velocity estimate's rms response to unit white position noise."""
    force_step: float | None = None
    """B·q·max|s_k| [N]: the damper force step of one encoder count (with requirements.quantization)."""
    force_noise_rms: float | None = None
    """B·q·sqrt(Σh_k²/12) [N rms] (with requirements.quantization)."""
    crossover_cutoff_ratio: float | None = None
    """the design's crossover frequency ω/(2π) over its cutoff (≈ 1 at a force-noise-limited ideal cutoff)."""
    note: str | None = None
