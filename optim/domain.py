"""Where the exact numerics are valid: checks of a device (and a virtual damping) before analysing it.

models.device.Device bounds each SI field on its own; the numerics depend on
the dimensionless combinations of chapter Table 1 (δ = bT/m, β = BT/m and the
scales m/T², m/T), and those can leave double precision even when every field
is in range: a subnormal mass makes δ infinite, a subnormal damping makes the
crossover scan's lowest frequency underflow (its grid size becomes infinite).
Found by fuzzing the HTTP API (tests/service/test_fuzz_api.py).

Each check raises ValueError("field: rule"), which the service answers as a
422 naming the field.  The limits are far outside any haptic device
(δ ≈ 6.5e-4 for the LHifAM) and inside the range swept by
tests/optim/test_domain.py, where every analysis returns finite numbers.  The same ratios bound the grasps
and filter cutoffs a request gives beside its device (check_human_domain, check_cutoff_domain), and every
device of a robust design's uncertainty box (optim.robust.box).

optim.stability.analysis and optim.stability.boundary also turn any floating-point overflow into a
ValueError naming the device; this check comes first and names the field and
the rule.
"""

from __future__ import annotations

from models.device import Device, Human
from optim.errors import InputError

__all__ = ["DELTA_MIN", "DELTA_MAX", "SCALE_MIN", "SCALE_MAX", "RATIO_MIN", "RATIO_MAX", "CUTOFF_RATIO_MIN",
           "check_device_domain", "check_human_domain", "check_human_mass", "check_cutoff_domain",
           "check_controller_domain", "SAMPLE_TIME_MIN", "SIGNAL_MIN", "check_sample_time", "check_signal_scale"]

#: Smallest non-zero δ = bT/m (below it the scan's lowest frequency ~1e-4·√δ underflows).
DELTA_MIN = 1e-30
#: Largest δ = bT/m (the ZOH pole e^{−δ} is 0 to double precision long before).
DELTA_MAX = 1e9
#: Range of the scales m/T² [N/m] and m/T [N·s/m] that turn dimensionless answers into SI ones:
#: normal doubles with room for the K and B they multiply.
SCALE_MIN = 1e-250
SCALE_MAX = 1e250
#: Range of every other non-zero dimensionless parameter (masses over m, stiffnesses over m/T², time
#: constants over T, dampings of the blocks over m/T): a cable, grasp or sensor 1e30 times smaller or
#: larger than the device is not a model double precision can carry next to it.
RATIO_MIN = 1e-30
RATIO_MAX = 1e30
#: Smallest filter cutoff relative to the sampling rate, f_c·T (θ_c = 2π·f_c·T rad per sample).  Down to it the
#: exact K_f,cr follows the first-order filter's scaling law K_f,cr ∝ 1/θ_c and agrees with the 40-digit
#: reference; at 1e-12 the reference rung's scan misses the crossover the exact rung finds, and below ~1e-15
#: the exact answer stops scaling (tests/optim/test_domain.py).  1e-9 is 1 µHz at 1 kHz: no force filter.
CUTOFF_RATIO_MIN = 1e-9


#: Smallest sample time [s].  With it (and mass ≤ 1e12) the scales m/T² and m/T can only leave their range
#: through the mass, so each rule names the field at fault (a subnormal sample_time was blamed on
#: device.mass: issue 29).  Far below any loop (1e-100 s); T² stays a normal double.
SAMPLE_TIME_MIN = 1e-100
#: Smallest magnitude of a measured signal's scale (the largest |force|, the position's range, the largest
#: |X/F|) an identification can fit: the fit squares and divides by them (forces of 1e-310 N divided by zero,
#: issue 28).  1e-100 keeps the squares normal doubles.
SIGNAL_MIN = 1e-100


def check_sample_time(sample_time: float, field: str) -> None:
    """``field`` (a sample time [s]) at least SAMPLE_TIME_MIN (the upper limit, 1 s, is the schemas' own)."""
    if not sample_time >= SAMPLE_TIME_MIN:
        raise InputError(field, f"must be ≥ {SAMPLE_TIME_MIN:g} s for double-precision analysis (got "
                                f"{sample_time:.3g} s; the loop's period squared must stay a normal double)")


def check_signal_scale(scale: float, field: str, what: str) -> None:
    """A measured signal's ``scale`` (its largest magnitude or range, ``what``) at least SIGNAL_MIN."""
    if not scale >= SIGNAL_MIN:
        raise InputError(field, f"{what} is {scale:.3g}: at least {SIGNAL_MIN:g} is needed for double-precision "
                                "fitting (check the units: N, m)")


def _ratio(field: str, value: float, scale: float, what: str, zero_ok: bool) -> None:
    if value == 0.0 and zero_ok:
        return
    r = value / scale
    if not (RATIO_MIN <= r <= RATIO_MAX):
        raise InputError(field, f"{what} = {r:.3g} must be {'0 or ' if zero_ok else ''}within "
                         f"[{RATIO_MIN:g}, {RATIO_MAX:g}] for double-precision analysis")


def check_human_domain(human: Human, device: Device, field: str) -> None:
    """The grasp ``human`` (named ``field``, e.g. "requirements.humans.0") next to ``device``: the ratios
    human mass/mass, damping·T/mass and stiffness·T²/mass within [RATIO_MIN, RATIO_MAX] (damping and stiffness
    may be 0), as for the device's own human block.  A subnormal grasp mass otherwise makes 0/0 in the
    grasp model."""
    m, t = device.mass, device.sample_time
    check_human_mass(human.mass, device, f"{field}.mass")
    _ratio(f"{field}.damping", human.damping, m / t, "human damping·sample_time/mass", zero_ok=True)
    _ratio(f"{field}.stiffness", human.stiffness, m / t / t, "human stiffness·sample_time²/mass", zero_ok=True)


def check_human_mass(mass: float, device: Device, field: str) -> None:
    """A grasp mass (named ``field``, e.g. "requirements.human_mass_range.min") with mass/device mass within
    [RATIO_MIN, RATIO_MAX]."""
    _ratio(field, mass, device.mass, "human mass/mass", zero_ok=False)


def check_controller_domain(value: float, device: Device, kind: str, field: str) -> None:
    """A stiffness (``kind`` "stiffness": K·T²/m, chapter Table 1's α) or damping ("damping": B·T/m, β) that a
    request asks for or caps, named ``field``, within [RATIO_MIN, RATIO_MAX].  A subnormal cap or target
    otherwise divides by zero in the design's scaling, or gives an infinite gain margin."""
    m, t = device.mass, device.sample_time
    scale, what = (m / t / t, "stiffness·sample_time²/mass (α)") if kind == "stiffness" else \
        (m / t, "damping·sample_time/mass (β)")
    _ratio(field, value, scale, what, zero_ok=False)


def check_cutoff_domain(cutoff_hz: float, sample_time: float, field: str) -> None:
    """A filter cutoff (named ``field``) with f_c·T ≥ CUTOFF_RATIO_MIN; the upper limit, the Nyquist
    frequency (f_c·T < 1/2), is models.filters.ButterworthLowPass's own rule."""
    r = cutoff_hz * sample_time
    if not r >= CUTOFF_RATIO_MIN:
        raise InputError(field, f"cutoff_hz·sample_time = {r:.3g} must be ≥ {CUTOFF_RATIO_MIN:g} for "
                         f"double-precision analysis (a cutoff of at least {CUTOFF_RATIO_MIN / sample_time:.3g} Hz "
                         f"at this sample time)")


def check_device_domain(device: Device) -> None:
    """Raise ValueError("field: rule") if the device's dimensionless numbers leave the validated domain."""
    check_sample_time(device.sample_time, "sample_time")
    # m/T/T, not m/T**2: T² of a subnormal T underflows to 0 (a ZeroDivisionError); the quotient overflows to inf.
    scales = (device.mass / device.sample_time / device.sample_time, device.mass / device.sample_time)
    if not all(SCALE_MIN <= s <= SCALE_MAX for s in scales):
        raise InputError("mass", f"mass/sample_time² and mass/sample_time must lie within [{SCALE_MIN:g}, "
                         f"{SCALE_MAX:g}] for double-precision analysis (mass {device.mass:g}, "
                         f"sample_time {device.sample_time:g})")
    delta = device.delta
    # b > 0 with δ underflowing to 0 counts as out of range: the numerics would treat it as undamped.
    if device.damping != 0.0 and not (DELTA_MIN <= delta <= DELTA_MAX):
        raise InputError("damping", f"the dimensionless damping δ = damping·sample_time/mass = {delta:.3g} must be 0 or "
                         f"within [{DELTA_MIN:g}, {DELTA_MAX:g}] (chapter Table 1)")
    m, t = device.mass, device.sample_time
    k_scale, b_scale = m / t / t, m / t
    if device.cable is not None:
        c = device.cable
        _ratio("cable.motor_mass", c.motor_mass, m, "motor_mass/mass", zero_ok=False)
        _ratio("cable.body_mass", c.body_mass, m, "body_mass/mass", zero_ok=False)
        _ratio("cable.stiffness", c.stiffness, k_scale, "stiffness·sample_time²/mass", zero_ok=False)
        for name in ("motor_damping", "body_damping", "damping"):
            _ratio(f"cable.{name}", getattr(c, name), b_scale, f"{name}·sample_time/mass", zero_ok=True)
    if device.human is not None:
        h = device.human
        _ratio("human.mass", h.mass, m, "human mass/mass", zero_ok=False)
        _ratio("human.damping", h.damping, b_scale, "human damping·sample_time/mass", zero_ok=True)
        _ratio("human.stiffness", h.stiffness, k_scale, "human stiffness·sample_time²/mass", zero_ok=True)
    if device.force_sensor is not None:
        _ratio("force_sensor.time_constant", device.force_sensor.time_constant, t, "time_constant/sample_time",
               zero_ok=True)
    if device.encoder_resolution is not None:
        # 2f_c/q (Abbott & Okamura) and the describing function's q/A must stay normal numbers.
        _ratio("encoder_resolution", device.encoder_resolution, 1.0, "encoder_resolution [m or rad]", zero_ok=False)
    if device.coulomb_friction is not None:
        _ratio("coulomb_friction", device.coulomb_friction, k_scale, "coulomb_friction·sample_time²/mass (m)",
               zero_ok=True)
