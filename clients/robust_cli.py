"""Client calls for robust and hardware design (issue 12), for the lead to wire into the CLI and client.

HTTP only (httpx), plus a typer sub-app ``robust_app`` (``app.add_typer(robust_app, name="robust")``):

    zwidth robust stiffness --preset lhifam --rigid --range device.mass=4:7 --range device.delay=0:0.002
    zwidth robust hardware --preset lhifam --rigid --free delay --stiffness 2e5
    zwidth robust hardware --preset lhifam --rigid --free delay --stiffness 2e5 --force-gain 5
    zwidth robust hardware --preset lhifam --rigid --free mass --apparent-mass 0.5
"""

from __future__ import annotations

import json
from typing import Any

import httpx
import typer

__all__ = ["robust_stiffness", "robust_inertia", "hardware", "plot", "robust_app", "parse_range"]

DEFAULT_URL = "http://127.0.0.1:8000"
_DESIGN_TIMEOUT = httpx.Timeout(120.0, connect=5.0)      # a robust design may take seconds


def _post(base_url: str, path: str, body: dict, params: dict | None = None) -> httpx.Response:
    r = httpx.post(base_url.rstrip("/") + path, json=body, params=params, timeout=_DESIGN_TIMEOUT)
    r.raise_for_status()
    return r


def robust_stiffness(device: dict, uncertainty: dict[str, tuple[float, float]], requirements: dict | None = None,
                     base_url: str = DEFAULT_URL) -> dict[str, Any]:
    """POST /v1/design/stiffness with requirements.uncertainty = {path: {min, max}}."""
    req = dict(requirements or {})
    req["uncertainty"] = {k: {"min": lo, "max": hi} for k, (lo, hi) in uncertainty.items()}
    return _post(base_url, "/v1/design/stiffness", {"device": device, "requirements": req}).json()


def robust_inertia(device: dict, uncertainty: dict[str, tuple[float, float]], requirements: dict | None = None,
                   base_url: str = DEFAULT_URL) -> dict[str, Any]:
    """POST /v1/design/inertia with requirements.uncertainty."""
    req = dict(requirements or {})
    req["uncertainty"] = {k: {"min": lo, "max": hi} for k, (lo, hi) in uncertainty.items()}
    return _post(base_url, "/v1/design/inertia", {"device": device, "requirements": req}).json()


def hardware(device: dict, free: str, stiffness: float | None = None, min_gain_margin_db: float = 6.0,
             max_damping: float | None = None, points: int = 41, base_url: str = DEFAULT_URL, *,
             force_gain: float | None = None, apparent_mass: float | None = None) -> dict[str, Any]:
    """POST /v1/design/hardware: a wall stiffness [N/m] and/or a force gain K_f or apparent mass [kg] target."""
    target: dict[str, Any] = {"min_gain_margin_db": min_gain_margin_db}
    for key, value in (("stiffness", stiffness), ("max_damping", max_damping), ("force_gain", force_gain),
                       ("apparent_mass", apparent_mass)):
        if value is not None:
            target[key] = value
    return _post(base_url, "/v1/design/hardware", {"device": device, "target": target, "free": free,
                                                   "points": points}).json()


def plot(kind: str, body: dict, fmt: str = "png", base_url: str = DEFAULT_URL) -> bytes:
    """POST /v1/plots/robust or /v1/plots/hardware (kind = "robust" | "hardware"): the image bytes."""
    return _post(base_url, f"/v1/plots/{kind}", body, params={"format": fmt}).content


def parse_range(text: str) -> tuple[str, tuple[float, float]]:
    """'device.mass=4:7' → ('device.mass', (4.0, 7.0))."""
    path, _, rng = text.partition("=")
    lo, _, hi = rng.partition(":")
    if not path or not lo or not hi:
        raise typer.BadParameter(f"expected PATH=MIN:MAX, got {text!r}")
    return path.strip(), (float(lo), float(hi))


def _device(preset: str, rigid: bool) -> dict:
    return {"preset": preset, "cable": None} if rigid else {"preset": preset}


robust_app = typer.Typer(help="Robust designs over parameter ranges, and the hardware a target needs.",
                         no_args_is_help=True)


@robust_app.command("stiffness")
def _stiffness_cmd(preset: str = typer.Option("lhifam"), rigid: bool = typer.Option(False),
                   range_: list[str] = typer.Option(..., "--range", help="PATH=MIN:MAX, repeatable"),
                   margin: float = typer.Option(6.0, help="min gain margin [dB]"),
                   url: str = typer.Option(DEFAULT_URL)) -> None:
    """The stiffest wall whose margin holds for every device of the box."""
    unc = dict(parse_range(r) for r in range_)
    typer.echo(json.dumps(robust_stiffness(_device(preset, rigid), unc, {"min_gain_margin_db": margin}, url),
                          indent=2))


@robust_app.command("hardware")
def _hardware_cmd(free: str = typer.Option(..., help="sample_time | delay | damping | mass | cable.stiffness"),
                  stiffness: float | None = typer.Option(None, help="target K [N/m]"),
                  force_gain: float | None = typer.Option(None, help="target force-feedforward gain K_f"),
                  apparent_mass: float | None = typer.Option(None, help="target apparent mass m/(1 + K_f) [kg]"),
                  margin: float = typer.Option(6.0), max_damping: float | None = typer.Option(None),
                  points: int = typer.Option(41, help="points of the trade-off curve"),
                  preset: str = typer.Option("lhifam"), rigid: bool = typer.Option(False),
                  url: str = typer.Option(DEFAULT_URL)) -> None:
    """The loosest value of one hardware parameter that still renders the target(s)."""
    out = hardware(_device(preset, rigid), free, stiffness, margin, max_damping, points, url,
                   force_gain=force_gain, apparent_mass=apparent_mass)
    out.pop("curve", None)
    typer.echo(json.dumps(out, indent=2))
