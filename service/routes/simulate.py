"""POST /v1/simulate: run a scene (models.simulation.simulate) and, for a relay, read it like a lab (optim.relay.experiment)."""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any, Callable

from fastapi import APIRouter

from models.device import Device
from models.simulation.friction import FrictionEventLimit
from models.simulation.scene import Scene
from models.simulation.simulate import SimulationResult, check_cost
from optim.errors import InputError
from optim.relay.experiment import RelayReport

from ..cost import simulation_cost_ms
from ..errors import numerics_refused
from ..executor import BoundedExecutor, Compute
from ..jobs import simulate_job
from ..schemas.simulate import SimulateRequest, SimulateResponse

if TYPE_CHECKING:
    from optim.relay.experiment import RelayReport

router = APIRouter(tags=["simulation"])


def _field_error(exc: ValueError) -> InputError:
    """An InputError names its field; any other ValueError of the simulator is about the scene."""
    return exc if isinstance(exc, InputError) else numerics_refused(exc, "scene")


async def run_scene(device: Device, scene: Scene, compute: BoundedExecutor, job: Callable = simulate_job,
                    *extra: Any) -> Any:
    """Validate the cost, run ``job(device, scene, *extra)`` (by default: simulate and analyse a relay) inline
    when short, else in a compute worker under the request time budget; ValueErrors name the field."""
    try:
        check_cost(device, scene)
        cost = simulation_cost_ms(device, scene) if job is simulate_job else None   # a drawing: always a worker
        return await compute.arun(job, device, scene, *extra, cost_ms=cost)
    except ValueError as exc:
        raise _field_error(exc) from exc
    except FrictionEventLimit as exc:   # the event integrator will not guess through a Zeno-like chatter
        raise numerics_refused(exc, "scene") from exc


def _cycle(c) -> dict:
    return {"pattern": list(c.pattern), "period_samples": c.period_samples, "frequency": c.frequency,
            "force_amplitude": c.force_amplitude, "position_amplitude": c.position_amplitude,
            "ultimate_gain": c.ultimate_gain, "admissible": c.admissible, "sign_margin": c.sign_margin}


def _runs(ns: list[int]) -> list[list[int]]:
    out: list[list[int]] = []
    for n in ns:
        if out and out[-1][1] == n - 1:
            out[-1][1] = n
        else:
            out.append([n, n])
    return out


def _relay_out(rep: "RelayReport") -> dict:
    s = rep.settled
    settled = None
    if s is not None:
        settled = {k: getattr(s, k) for k in (
            "repeats", "symmetric", "half_period_min", "half_period_max", "frequency", "force_amplitude",
            "position_amplitude", "ultimate_gain", "ultimate_gain_min", "ultimate_gain_max", "mean_position",
            "force_amplitude_error", "position_amplitude_error", "frequency_error")}
        settled |= {"pattern": list(s.pattern) if s.pattern else None, "half_periods": list(s.half_periods),
                    "exact": _cycle(s.exact) if s.exact else None}
    crit = rep.critical_stiffness
    co = lambda c: {"frequency": c.frequency, "stiffness": c.stiffness}  # noqa: E731
    return {"amplitude": rep.amplitude, "start_position": rep.start_position, "start_velocity": rep.start_velocity,
            "settled": settled, "reason": rep.reason, "critical_stiffness": crit.critical_stiffness,
            "crossovers": [co(c) for c in crit.crossovers],
            "nearest_crossover": co(rep.nearest_crossover) if rep.nearest_crossover else None,
            "ultimate_gain_error": rep.ultimate_gain_error, "cycles": [_cycle(c) for c in rep.cycles],
            "admissible_half_periods": _runs([c.pattern[0] for c in rep.cycles if c.admissible]),
            "searched_half_periods": rep.searched_half_periods,
            "admissible_gain_range": list(rep.admissible_gain_range) if rep.admissible_gain_range else None,
            "notes": list(rep.notes)}


def _measured(m) -> dict:
    return {"state": m.state, "frequency": m.frequency, "amplitude": float(m.amplitude),
            "growth_rate": m.growth_rate, "reason": m.reason,
            "decisive_duration": m.decisive_duration}


def _poles(p, linearised: bool) -> dict:
    dom = {"modulus": p.dominant_modulus, "angle": p.dominant_angle, "frequency": p.dominant_frequency,
           "growth_rate": p.growth_rate}
    return {"state": p.state, "spectral_radius": p.spectral_radius, "dominant_pole": dom, "rounding": p.rounding,
            "states": p.states, "free_position_pole": p.free_position_pole, "linearised": linearised,
            "method": p.method, "reason": p.reason}


def verdict_out(res: SimulationResult) -> dict:
    """The verdict block: the answer (its old fields unchanged) plus the measured verdict, the poles and any
    disagreement (models/simulation/verdict.py)."""
    j, v = res.judgement, res.verdict
    return {"state": v.state, "frequency": v.frequency, "amplitude": float(v.amplitude),
            "growth_rate": v.growth_rate, "reason": v.reason, "decided_by": j.decided_by,
            "measured": _measured(j.measured), "poles": _poles(j.poles, j.poles_linearised) if j.poles else None,
            "poles_note": j.poles_note, "disagreement": j.disagreement}


@router.post("/v1/simulate", response_model=SimulateResponse)
async def simulate_scene(req: SimulateRequest, compute: Compute) -> SimulateResponse:
    start = time.perf_counter()
    res, relay = await run_scene(req.device, req.scene, compute)
    tr = res.trajectory
    return SimulateResponse(
        effects_simulated=list(res.effects_simulated), not_simulated=list(res.not_simulated), method=res.method,
        sample_time=res.sample_time, samples=res.samples, samples_run=res.samples_run, diverged_at=res.diverged_at,
        trajectory={"time": tr.time.tolist(), "motor_position": tr.motor_position.tolist(),
                    "body_position": tr.body_position.tolist(), "force": tr.force.tolist(),
                    "energy_generated": tr.energy_generated.tolist()},
        verdict=verdict_out(res),
        energy_generated=res.energy_generated, energy_generated_max=res.energy_generated_max,
        energy_generated_second_half=res.energy_generated_second_half,
        relay=_relay_out(relay) if relay else None, elapsed_ms=1e3 * (time.perf_counter() - start))
