"""The verdict of a scene: the exact one from the closed-loop poles when the scene is linear (or from
K_cr(B) beyond the poles' size limit, optim/scene_verdict.py), the measured one (models/simulation/oscillation.py)
otherwise, and any disagreement between them said aloud.

A linear scene is decided by its poles (models/simulation/scene_poles.py): ``stable`` / ``unstable``; when a pole
sits on the unit circle within rounding the poles cannot decide, and the measured verdict stands (most
often ``undetermined``), with the poles' reason beside it.  The measured verdict is kept
beside it; when the two disagree (measured stable or unstable against the poles), the answer says so
in ``disagreement`` and the poles decide.  A nonlinear scene keeps its measured verdict; the poles of
its linear part, when computed, are information only.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from models.simulation.oscillation import Verdict, VerdictState
from models.simulation.scene_poles import ScenePoles

__all__ = ["SceneVerdict", "decide", "decide_exact"]

_FROM_POLES: dict[str, VerdictState] = {"stable": "stable", "unstable": "unstable", "marginal": "undetermined"}


@dataclass(frozen=True)
class SceneVerdict:
    verdict: Verdict
    """the answer: decided by the poles for a linear scene, by the trajectory otherwise."""
    measured: Verdict
    """what the trajectory alone shows (three-valued, plus limit_cycle for nonlinear scenes)."""
    poles: ScenePoles | None
    """closed-loop poles: exact for a linear scene, of the linear part (information) otherwise."""
    poles_linearised: bool
    """the poles are those of the scene without its nonlinear effects (information only)."""
    poles_note: str | None
    """why no poles were computed (None when they were)."""
    decided_by: Literal["closed-loop poles", "critical stiffness", "trajectory"]
    disagreement: str | None
    """the measured verdict contradicts the poles (linear scenes): said, and the poles decide."""


def _disagreement(measured: Verdict, poles: ScenePoles) -> str | None:
    exact = _FROM_POLES[poles.state]
    if measured.state in ("stable", "unstable") and measured.state != exact:
        return (f"the trajectory alone says {measured.state} ({measured.reason}) but the closed-loop poles say "
                f"{poles.state} ({poles.reason}); the poles decide")
    return None


def decide(measured: Verdict, poles: ScenePoles | None, linear: bool, poles_note: str | None = None) -> SceneVerdict:
    if not linear or poles is None:
        top = measured
        if linear and poles is None and poles_note:
            top = Verdict(measured.state, measured.frequency, measured.amplitude, measured.growth_rate,
                          f"{measured.reason} (no exact verdict: {poles_note})", measured.decisive_duration)
        return SceneVerdict(top, measured, poles, not linear and poles is not None, poles_note, "trajectory", None)
    if poles.state == "marginal":
        # the poles cannot decide (a pole on the circle within rounding): what the record shows stands, said
        top = Verdict(measured.state, measured.frequency, measured.amplitude, measured.growth_rate,
                      f"{measured.reason}; the closed-loop poles cannot decide: {poles.reason}",
                      measured.decisive_duration)
        return SceneVerdict(top, measured, poles, False, None, "trajectory", None)
    state = _FROM_POLES[poles.state]
    top = Verdict(state, poles.dominant_frequency, measured.amplitude, poles.growth_rate, poles.reason, None)
    return SceneVerdict(top, measured, poles, False, None, "closed-loop poles", _disagreement(measured, poles))


def decide_exact(measured: Verdict, state: VerdictState, reason: str, method: Literal["critical stiffness"],
                 poles_note: str | None) -> SceneVerdict:
    """A linear scene decided exactly without its poles (optim/scene_verdict.py: K against K_cr(B))."""
    if state == "undetermined":
        top = Verdict(measured.state, measured.frequency, measured.amplitude, measured.growth_rate,
                      f"{measured.reason}; {method} cannot decide: {reason}", measured.decisive_duration)
        return SceneVerdict(top, measured, None, False, poles_note, "trajectory", None)
    top = Verdict(state, measured.frequency, measured.amplitude, measured.growth_rate, reason, None)
    disagreement = None
    if measured.state in ("stable", "unstable") and measured.state != state:
        disagreement = (f"the trajectory alone says {measured.state} ({measured.reason}) but the {method} says "
                        f"{state} ({reason}); the {method} decides")
    return SceneVerdict(top, measured, None, False, poles_note, method, disagreement)
