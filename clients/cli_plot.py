"""``zwidth plot boundary|bode|simulation``: the service's figures saved to a file (PNG or SVG)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from . import cli_common as c
from .cli_common import (
    DEFAULT_URL,
    Connection,
    DeviceFile,
    Local,
    Preset,
    SceneFile,
    Sets,
    Token,
    Url,
    open_client,
    out,
    scene_root,
)

app = typer.Typer(help="Figures drawn by the service, saved as PNG or SVG (by the output file's suffix).",
                  no_args_is_help=True)

Points = Annotated[int | None, typer.Option(help="points on the curve")]


def _format(path: Path) -> str:
    suffix = path.suffix.lower()
    if suffix not in (".png", ".svg"):
        raise c.usage_error(f"--out {path}: the file must end in .png or .svg")
    return suffix[1:]


def _save(plot, path: Path) -> None:
    plot.save(str(path))
    out.print(f"wrote {path} ({plot.media_type}, {len(plot.content):,} bytes)", markup=False)


@app.command("boundary")
@c.handle_errors
def boundary(preset: Preset = None, sets: Sets = None, device_file: DeviceFile = None,
             out_file: Annotated[Path, typer.Option("--out", "-o", help=".png or .svg")] = Path("boundary.png"),
             points: Points = None,
             damping_max: Annotated[float | None, typer.Option(help="largest B [N·s/m]; default B_max")] = None,
             velocity_filter: Annotated[str | None, typer.Option(
                 help="the velocity the damper sees: backward_difference | low_pass:F_HZ[:ORDER] | "
                      "moving_average:N")] = None,
             virtual_mass: Annotated[float | None, typer.Option(help="virtual mass M of the walls [kg]")] = None,
             local: Local = False, url: Url = DEFAULT_URL, token: Token = None) -> None:
    """The stability boundary K_cr(B) with its optimum (POST /v1/plots/boundary), for today's wall or the rendered
    one (--velocity-filter, --virtual-mass)."""
    from .cli import parse_velocity_filter

    fmt = _format(out_file)
    controller = None
    if velocity_filter is not None or virtual_mass is not None:
        controller = {**({"mass": virtual_mass} if virtual_mass is not None else {}),
                      **({"velocity_filter": parse_velocity_filter(velocity_filter)} if velocity_filter else {})}
    body = c.assemble({"device": c.device_root(preset, device_file, sets), "controller": controller}, sets)
    with open_client(Connection(local, url, token)) as zw, c.progress_status("drawing the boundary…", False):
        plot = zw.plot_boundary(body["device"], body.get("controller"), damping_max=damping_max, points=points,
                                format=fmt)
    _save(plot, out_file)


@app.command("bode")
@c.handle_errors
def bode(preset: Preset = None, sets: Sets = None, device_file: DeviceFile = None,
         out_file: Annotated[Path, typer.Option("--out", "-o", help=".png or .svg")] = Path("bode.png"),
         stiffness: Annotated[float | None, typer.Option(help="wall K [N/m] (its 1/K line is drawn)")] = None,
         damping: Annotated[float | None, typer.Option(help="wall B [N·s/m] (sets the crossovers marked)")] = None,
         points: Points = None, local: Local = False, url: Url = DEFAULT_URL, token: Token = None) -> None:
    """Bode diagram of the sampled loop with the crossovers of K_cr(B) marked (POST /v1/plots/bode)."""
    fmt = _format(out_file)
    controller = None
    if stiffness is not None:
        controller = {"stiffness": stiffness, **({"damping": damping} if damping is not None else {})}
    elif damping is not None:
        raise c.usage_error("--damping needs --stiffness (the wall is K + B(1 − z⁻¹)/T)")
    body = c.assemble({"device": c.device_root(preset, device_file, sets), "controller": controller}, sets)
    with open_client(Connection(local, url, token)) as zw, c.progress_status("drawing the Bode diagram…", False):
        plot = zw.plot_bode(body["device"], body.get("controller"), points=points, format=fmt)
    _save(plot, out_file)


@app.command("simulation")
@c.handle_errors
def simulation(preset: Preset = None, sets: Sets = None, device_file: DeviceFile = None,
               scene_file: SceneFile = None,
               out_file: Annotated[Path, typer.Option("--out", "-o", help=".png or .svg")] = Path("simulation.png"),
               experiment: Annotated[str | None, typer.Option(help="release | push | relay")] = None,
               duration: Annotated[float | None, typer.Option(help="simulated time [s]")] = None,
               stiffness: Annotated[float | None, typer.Option(help="wall K [N/m]")] = None,
               damping: Annotated[float | None, typer.Option(help="wall B [N·s/m]")] = None,
               position: Annotated[float | None, typer.Option(help="initial position [m]")] = None,
               local: Local = False, url: Url = DEFAULT_URL, token: Token = None) -> None:
    """A simulated scene drawn as position, force and energy (POST /v1/plots/simulation)."""
    fmt = _format(out_file)
    body = c.assemble({"device": c.device_root(preset, device_file, sets),
                       "scene": scene_root(experiment, duration, stiffness, damping, position, None, None,
                                           None)},
                      sets, files={"scene": scene_file})
    with open_client(Connection(local, url, token)) as zw, c.progress_status("simulating and drawing…", False):
        plot = zw.plot_simulation(body["device"], body["scene"], format=fmt)
    _save(plot, out_file)


@app.command("study")
@c.handle_errors
def study(study_id: Annotated[str, typer.Argument(help="study id (from `zwidth study run`)")],
          y: Annotated[str, typer.Option(help="result column to draw, e.g. stiffness or critical_stiffness")],
          x: Annotated[str, typer.Option(help="swept path on the x axis, e.g. device.delay")],
          x2: Annotated[str | None, typer.Option(help="second swept path: draws a map")] = None,
          out_file: Annotated[Path, typer.Option("--out", "-o", help=".png or .svg")] = Path("study.png"),
          url: Url = DEFAULT_URL, token: Token = None) -> None:
    """A study's result against its swept parameters (GET /v1/studies/{id}/plot)."""
    fmt = _format(out_file)
    with open_client(Connection(False, url, token)) as zw, c.progress_status("drawing the study…", False):
        plot = zw.plot_study(study_id, y, x, x2=x2, format=fmt)
    _save(plot, out_file)
