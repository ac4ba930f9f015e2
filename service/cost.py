"""What a request will cost, before it runs: the cost limits and the inline-or-worker choice.

The estimates are coarse (a factor of 2 either way is fine): they only decide
whether a call runs inline in the request thread (cheap, fast path) or in a
killable worker process under the request time budget (service.executor).
Coefficients measured on the 2-core development machine (bench/bench_service.py
and docs/limits.md): the full exact rigid analysis (issue 20's fast path: K_cr, every
crossover, passivity) ≈ 0.05 ms plus ≈ 2.5-3 µs per sample of delay (one crossover
every other sample), up to 2× with virtual damping, estimated as 0.1 ms + 4 µs per
sample (× 2 with B); the cable paths (bounded scan) and the designs keep the older
rigid unit of 1 ms + 6 µs per sample, about 3× that for a cable device and 2× with
virtual damping (B_max is found too);
the 40-digit reference rung ≈ 0.12 s plus 12 ms per sample of delay (10× for a cable).
"""

from __future__ import annotations

from models.device import Device
from models.velocity_filter import Rendering

from .errors import NumericInputError

__all__ = ["REFERENCE_REQUEST_BUDGET_DELAY_SAMPLES", "RENDERED_COST_FACTOR", "check_reference_cost",
           "rendered_cost_ms", "filter_cost_ms", "stability_cost_ms", "boundary_cost_ms", "bode_cost_ms",
           "stiffness_design_cost_ms", "inertia_design_cost_ms", "force_feedforward_cost_ms", "simulation_cost_ms"]

#: Request-time budget of ``method = reference`` on the analysis routes: the loop delay an HTTP request may ask
#: the 40-digit rung for, in sample periods. At this limit one reference analysis costs ≈ 2.5 s (rigid) to ≈ 25 s
#: (cable). A budget rule of the service, tighter than the rung's own cap (optim.stability.reference); see
#: docs/limits.md.
REFERENCE_REQUEST_BUDGET_DELAY_SAMPLES = 200


#: Extra cost of an exact analysis of a cable device without cable damping (see :func:`_exact_ms`).
UNDAMPED_CABLE_FACTOR = 3.0


def check_reference_cost(device: Device, method: str) -> None:
    """422 naming ``method`` when the 40-digit rung would exceed its documented cost limit."""
    if method == "reference" and device.delay_samples > REFERENCE_REQUEST_BUDGET_DELAY_SAMPLES:
        raise NumericInputError(
            "method", f"the reference rung accepts at most {REFERENCE_REQUEST_BUDGET_DELAY_SAMPLES} samples of delay "
                      f"(delay / sample_time = {device.delay_samples:.6g}); use method=exact, which is exact "
                      "to 1e-12 at any delay")


def _exact_ms(device: Device, damping: float) -> float:
    ms = 1.0 + 0.006 * device.delay_samples
    if device.cable is not None:
        # An undamped cable (b_c = 0) costs ≈ 2-3× a damped one (lightly damped modes: more crossovers and
        # closer roots); measured on the loaded 2-core machine, 2026-12-03: up to 2.9× the old estimate at 50
        # samples of delay (issue 28: 11 ms estimated, 80 ms real, run inline)
        ms *= 3.0 * (UNDAMPED_CABLE_FACTOR if device.cable.damping == 0 else 1.0)
    if damping > 0:
        ms *= 2.0
    return ms


def stability_cost_ms(device: Device, method: str, damping: float, grid_points: int) -> float:
    """Estimated cost [ms] of one ``analyse_stability`` call."""
    if method == "linear":
        return 0.1
    if method == "grid":
        return 0.5 + 3e-4 * grid_points * (4.0 if device.cable is not None else 1.0)
    if method == "reference":
        return (120.0 + 12.0 * device.delay_samples) * (10.0 if device.cable is not None else 1.0)
    if device.cable is None:
        return (0.1 + 0.004 * device.delay_samples) * (2.0 if damping > 0 else 1.0)
    return _exact_ms(device, damping) * 2.0  # the cable's analysis adds the rigid K_cr


#: A rendered wall takes the scan (and the K → 0⁺ loop's two): its cost estimate is today's path's times this, plus
#: :func:`filter_cost_ms` per analysis.
RENDERED_COST_FACTOR = 10


def filter_cost_ms(rendered: Rendering) -> float:
    """Extra cost [ms] of one rendered analysis for its velocity filter's order n (the coefficients of R and D
    beyond the first: a moving average of n samples has n − 1, each a zero on the unit circle the scan resolves
    and a state of the loop).  Measured (CPU time, one exact analysis of a rigid device, compiled kernels warm,
    the 2-core machine at load ≈ 5, 2026-12-04): n = 50: 26 ms, 100: 50 ms, 200: 150 ms, 400: 415 ms,
    1000: 2.3 s (a cable device 3.2 s); estimated 0.5 n + 2.5e-3 n² ms (31, 75, 200, 600, 3000 ms).  Before,
    a 1000-sample average of a rigid device was estimated at 1 ms and ran on the event loop for seconds."""
    n = len(rendered.velocity.r) + len(rendered.velocity.d) - 2
    return 0.5 * n + 2.5e-3 * n * n


def rendered_cost_ms(base_ms: float, rendered: Rendering | None, calls: float = 1.0) -> float:
    """Estimated cost [ms] of a call estimated at ``base_ms`` for today's wall, for the wall ``rendered`` (None:
    today's wall, ``base_ms``) making ``calls`` rendered analyses: the scan's factor and the filter's order."""
    if rendered is None:
        return base_ms
    return base_ms * RENDERED_COST_FACTOR + calls * filter_cost_ms(rendered)


def nonlinear_cost_ms(device: Device, damping: float) -> float:
    """Estimated cost [ms] of ``analyse_nonlinear`` (optim.stability.nonlinear): ~48 amplitudes of the harmonic
    balance plus its roots, each up to five exact K_cr (measured ≈ 0.1-0.2 s rigid, ≈ 1-2 s for the LHifAM cable)."""
    if not device.nonlinear:
        return 0.0
    return 300.0 * stability_cost_ms(device, "exact", damping, 0)


def nonlinear_verify_cost_ms(device: Device) -> float:
    """Estimated cost [ms] of ``verify_nonlinear``: two energy audits and a release, ≤ ~15,000 samples, ≈ 0.3 ms
    a sample with Coulomb friction (event integrator), ×3 for a cable, ≈ 0.02 ms without friction."""
    per = 0.3 if device.coulomb_friction else 0.02
    return 15_000 * per * (3.0 if device.cable is not None else 1.0)


def verify_cost_ms(device: Device) -> float:
    """Estimated cost [ms] of one ``verify`` (optim.verification): two or three closed loops, by eigenvalues up to
    160 states (≈ 1-10 ms), by the argument principle beyond (≈ 20 ms + 0.03 ms per sample of delay)."""
    return 5.0 + (20.0 + 0.03 * device.delay_samples if device.delay_samples > 150 else 10.0)


def boundary_cost_ms(device: Device, points: int) -> float:
    """Estimated cost [ms] of one ``stability_boundary`` call (B_max, the points, the refined optimum)."""
    return (points + 25) * _exact_ms(device, 1.0)


def bode_cost_ms(device: Device, damping: float, points: int) -> float:
    """Estimated cost [ms] of one ``loop_frequency_response`` call (one exact K_cr plus the grid)."""
    per_point = 0.02 if device.cable is not None else 0.001
    return _exact_ms(device, damping) + per_point * points


# Designs, robust designs and long simulations (issue 10).  Measured on the 2-core machine in a warm
# process (bench/bench_design_http.py; a worker's first design also builds its CasADi solver, which the
# forkserver does once in service._warm): exact rigid stiffness design ≈ 15-30 ms, cable alike;
# the grid rung scans 201 dampings × grid_points; the reference rung adds 40-digit checks (≈ 0.4 s);
# an inertia design ≈ 40-50 ms; the force-feedforward analysis ≈ 1.5-3 ms (exact), ≈ 0.75 µs per grid
# point, ≈ 0.15-0.25 s for the reference; simulations ≈ 1 µs (linear recursion), 10 µs (sampled loop,
# relay, quantisation, saturation) and 40 µs (event integrator, Coulomb friction) per sample, and a
# relay's analysis ≈ 0.1 s.  Robust designs and hardware designs (tens of exact designs) always go to a
# worker (cost None).

def _delay_factor(device: Device) -> float:
    return 1.0 + 0.006 * device.delay_samples


def stiffness_design_cost_ms(device: Device, method: str, grid_points: int) -> float:
    """Estimated cost [ms] of one ``design_stiffness_on_rung`` call (linear: inline; the others: a worker)."""
    cable = 4.0 if device.cable is not None else 1.0
    if method == "linear":
        return 0.1
    if method == "grid":
        return 5.0 + 201 * grid_points * 3e-5 * cable
    if method == "reference":
        return 400.0 * cable * _delay_factor(device)
    return 30.0 * _delay_factor(device)


def inertia_design_cost_ms(device: Device, method: str, grid_points: int, humans: int) -> float:
    """Estimated cost [ms] of one ``design_inertia_on_rung`` call (linear: inline; the others: a worker)."""
    if method == "linear":
        return 2.0 * max(humans, 1)
    if method == "grid":
        return 40.0 + 201 * grid_points * 7.5e-4 * max(humans, 1)
    if method == "reference":
        return 400.0 * max(humans, 1) * _delay_factor(device)
    return 50.0 * max(humans, 1) * _delay_factor(device)


def force_feedforward_cost_ms(device: Device, method: str, grid_points: int) -> float:
    """Estimated cost [ms] of one force-feedforward analysis (with the rigid comparison of a cable device)."""
    cable = 2.0 if device.cable is not None else 1.0
    if method == "linear":
        return 0.5
    if method == "grid":
        return 0.5 + 7.5e-4 * grid_points
    if method == "reference":
        return 250.0 * cable * _delay_factor(device)
    return 3.0 * cable * _delay_factor(device)


#: Cost per simulated sample [ms] of each propagation method of models.simulation.simulate.
_SIM_MS_PER_SAMPLE = {"exact-linear-recursion": 1e-3, "exact-sampled-loop": 1e-2, "event-integrator": 4e-2}


def simulation_cost_ms(device: Device, scene) -> float:
    """Estimated cost [ms] of one simulation (and, for a relay, its analysis ≈ 0.1 s: a worker)."""
    from models.simulation.simulate import propagation_method, sample_count

    ms = 1.0 + _SIM_MS_PER_SAMPLE[propagation_method(scene)] * sample_count(device, scene)
    # the verdict's closed-loop poles: dense eigenvalues of ~(delay line + 8) states (≤ 600), O(n³)
    states = 8 + (device.delay_samples if scene.effects.delay is not None else 0.0)
    ms += 3e-6 * min(states, 600.0) ** 3 if scene.experiment != "relay" else 0.0
    return ms + (100.0 if scene.experiment == "relay" else 0.0)
