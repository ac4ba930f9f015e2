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
tests/optim/test_domain.py, where every analysis returns finite numbers.

Also here, until it is fixed in optim.margins: a device with no physical
damping at all (b = 0) cannot yet be analysed with virtual damping B > 0 —
the B_max scan starts at a lowest frequency proportional to δ + β with β = 0,
i.e. at 0, and divides by zero.  The check turns that into a clear 422.
"""

from __future__ import annotations

from models.device import Device

__all__ = ["DELTA_MIN", "DELTA_MAX", "SCALE_MIN", "SCALE_MAX", "check_device_domain", "check_damping_domain"]

#: Smallest non-zero δ = bT/m (below it the scan's lowest frequency ~1e-4·√δ underflows).
DELTA_MIN = 1e-30
#: Largest δ = bT/m (the ZOH pole e^{−δ} is 0 to double precision long before).
DELTA_MAX = 1e9
#: Range of the scales m/T² [N/m] and m/T [N·s/m] that turn dimensionless answers into SI ones:
#: normal doubles with room for the K and B they multiply.
SCALE_MIN = 1e-250
SCALE_MAX = 1e250


def check_device_domain(device: Device) -> None:
    """Raise ValueError("field: rule") if the device's dimensionless numbers leave the validated domain."""
    # m/T/T, not m/T**2: T² of a subnormal T underflows to 0 (a ZeroDivisionError); the quotient overflows to inf.
    scales = (device.mass / device.sample_time / device.sample_time, device.mass / device.sample_time)
    if not all(SCALE_MIN <= s <= SCALE_MAX for s in scales):
        raise ValueError(f"mass: mass/sample_time² and mass/sample_time must lie within [{SCALE_MIN:g}, "
                         f"{SCALE_MAX:g}] for double-precision analysis (mass {device.mass:g}, "
                         f"sample_time {device.sample_time:g})")
    delta = device.delta
    # b > 0 with δ underflowing to 0 counts as out of range: the numerics would treat it as undamped.
    if device.damping != 0.0 and not (DELTA_MIN <= delta <= DELTA_MAX):
        raise ValueError(f"damping: the dimensionless damping δ = damping·sample_time/mass = {delta:.3g} must be 0 or "
                         f"within [{DELTA_MIN:g}, {DELTA_MAX:g}] (chapter Table 1)")


def check_damping_domain(device: Device, damping: float) -> None:
    """Virtual damping B [N·s/m] on this device (B = inf: a whole boundary): unsupported when b = 0."""
    if damping > 0.0 and device.damping == 0.0:
        raise ValueError("damping: a device with no physical damping (b = 0) cannot yet be analysed with "
                         "virtual damping B > 0 (the B_max scan is undefined at δ = 0); give the device b > 0")
