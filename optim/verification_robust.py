"""``verify`` for a robust design: the design checked on the closed loop at every corner of its box and at the
worst device it found.

A robust design claims that its controller keeps the required margin (and, when asked, passivity) for every
device of the box.  Finitely many devices can be checked: every corner of the box (over the parameters that
enter the loop; the others held at their nominal value, clipped into the box) and the worst device the
design's own search found (and, with passivity, its least passive device).  At each of them:

* the project's exact analysis gives the critical gain there (optim.stability.margins for K_cr(B),
  optim.transparency.feedforward for K_f,cr at the design's cutoff), and the margin it implies;
* that critical gain is checked independently like any answer (optim.verification: the closed loop just
  below and just above it, by eigenvalues or an argument-principle count), and so is the designed gain
  itself (stable) and, when required, passivity (recomputed from the complex form);
* the margin must be at least the required one: a device of the box below it contradicts the design.

The overall verdict is ``contradicted`` if any point contradicts, else ``not_checkable`` (with the points'
reasons) if any point cannot be decided, else ``confirmed``; every point's own verdict is listed.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Literal

import numpy as np

from models.device import Device
from models.filters import ButterworthLowPass
from optim.robust.box import STIFFNESS_PATHS, UncertaintyBox
from optim.stability.margins import critical_stiffness
from optim.transparency.feedforward import critical_force_gain, resolve_human
from optim.verification import Verdict, Verification, labelled, verify_critical_force_gain, verify_stiffness_design

__all__ = ["PointVerification", "verify_robust_inertia", "verify_robust_stiffness"]

PointKind = Literal["corner", "worst", "least passive"]

#: a point's margin may fall short of the requirement by the rounding of 20·log10 of a ratio (a robust design
#: sits on its worst device: the inertia design at K_f = K_f,cr(worst)/10^(GM/20) exactly), and no more
MARGIN_TOL_DB = 1e-9


@dataclass(frozen=True)
class PointVerification:
    """One checked device of the box."""

    device: dict[str, float]
    """the uncertain parameters' values at this device (path → value, SI units)."""
    kind: PointKind
    """corner of the box, the worst device the design found, or (passivity) its least passive device."""
    critical_gain: float | None
    """K_cr(B) [N/m] (stiffness) or K_f,cr at the design's cutoff (inertia) of this device, exact analysis."""
    gain_margin_db: float | None
    """20·log10(critical_gain/designed gain) [dB]."""
    verdict: Verdict
    method: str | None
    reason: str | None


def _points(box: UncertaintyBox, relevant: np.ndarray, extra: list[tuple[PointKind, dict | None]]):
    """Every corner over the relevant parameters (the others at their nominal value), then the named points."""
    nominal = box.nominal_point()
    corners = np.unique(np.where(relevant, box.corners(), nominal), axis=0)
    pts: list[tuple[PointKind, np.ndarray]] = [("corner", c) for c in corners]
    for kind, values in extra:
        if values:
            x = np.array([float(values.get(p, v)) for p, v in zip(box.paths, nominal)])
            if not any(np.array_equal(x, c) for _, c in pts):
                pts.append((kind, x))
    return pts


def _overall(points: list[PointVerification], t0: float, what: str) -> Verification:
    counts = {"confirmed": 0, "contradicted": 0, "not_checkable": 0}
    for p in points:
        counts[p.verdict] += 1
    verdict: Verdict = ("contradicted" if counts["contradicted"] else
                        "not_checkable" if counts["not_checkable"] else "confirmed")
    bad = [f"{p.kind} {', '.join(f'{k} = {v:.6g}' for k, v in p.device.items())}: {p.verdict} ({p.reason})"
           for p in points if p.verdict != "confirmed"][:3]
    reason = (f"{len(points)} devices of the box ({what}): {counts['confirmed']} confirmed, "
              f"{counts['contradicted']} contradicted, {counts['not_checkable']} not checkable"
              + ("; " + "; ".join(bad) if bad else ""))
    methods = "; ".join(dict.fromkeys(p.method for p in points if p.method)) or None
    out = Verification(verdict, methods, None, None, None, None, None, None, None,
                       (time.perf_counter() - t0) * 1e3, reason, points=tuple(points))
    return labelled(out, f"the design holds on each of the {len(points)} devices of the box ({what}): its critical "
                         "gain there, the designed gain stable (and passive when required), the margin")


def _point(device: dict, kind: PointKind, critical: float | None, gained: float, required_db: float,
           v: Verification) -> PointVerification:
    """critical: None when every gain is stable there (margin +inf), 0 when none is (margin −inf)."""
    margin = math.inf if critical is None else 20.0 * math.log10(critical / gained) if critical > 0 else -math.inf
    verdict, reasons = v.verdict, [v.reason] if v.reason and v.verdict != "confirmed" else []
    if not margin >= required_db - MARGIN_TOL_DB:
        verdict = "contradicted"
        reasons.insert(0, f"the margin here is {margin:.9g} dB, below the required {required_db:g} dB")
    return PointVerification(device, kind, critical, margin, verdict, v.method, "; ".join(reasons) or None)


def verify_robust_stiffness(box: UncertaintyBox, stiffness: float, damping: float, min_gain_margin_db: float,
                            passivity: bool, worst: dict | None = None,
                            least_passive: dict | None = None) -> Verification:
    """Check a robust wall (K, B) at every corner of its box and at the worst (and least passive) device found.

    ``worst`` / ``least_passive``: the design's ``worst_case["device"]`` / ``passivity_worst_case["device"]``
    (path → value)."""
    t0 = time.perf_counter()
    relevant = box.relevant(STIFFNESS_PATHS)
    out = []
    for kind, x in _points(box, relevant, [("worst", worst), ("least passive", least_passive)]):
        dev = box.device_at(x)
        kcr = critical_stiffness(dev, damping).critical_stiffness
        kcr = None if kcr is None or math.isinf(kcr) else float(kcr)
        # the critical gain of this device (not one implied by a margin): checked ± ε, K itself, passivity
        v = verify_stiffness_design(dev, stiffness, damping, None, True if passivity else None, critical=kcr)
        out.append(_point(box.describe(x), kind, kcr, stiffness, min_gain_margin_db, v))
    return _overall(out, t0, "every corner and the worst device found")


def verify_robust_inertia(box: UncertaintyBox, force_gain: float, cutoff_hz: float, order: int,
                          min_gain_margin_db: float, worst: dict | None = None) -> Verification:
    """Check a robust force-feedforward design (K_f, cutoff) at every corner of its box and its worst device."""
    t0 = time.perf_counter()
    out = []
    for kind, x in _points(box, np.ones(box.dim, bool), [("worst", worst)]):
        dev: Device = box.device_at(x)
        human, _ = resolve_human(dev)
        filt = ButterworthLowPass(order=order, cutoff_hz=cutoff_hz, sample_time=dev.sample_time)
        kcr = float(critical_force_gain(dev, filt, human).critical_force_gain)
        kcr_or_none = None if math.isinf(kcr) else kcr
        v = verify_critical_force_gain(dev, human, kcr_or_none, order, cutoff_hz, design_gain=force_gain)
        out.append(_point(box.describe(x), kind, kcr_or_none, force_gain, min_gain_margin_db, v))
    return _overall(out, t0, "every corner and the worst device found")
