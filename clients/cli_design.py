"""``zwidth design stiffness|inertia``: the safest controller the device allows (POST /v1/design/*).

Exit 1 when the design is ``infeasible``, ``failed`` or ``unsafe`` (no safe design delivered).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from . import cli_common as c
from .cli_common import DEFAULT_URL, AsJson, Connection, DeviceFile, Local, Preset, Sets, Token, Url

app = typer.Typer(help="Design a controller: the stiffest wall, or the lightest feel (force feedforward).",
                  no_args_is_help=True)

Margin = Annotated[float | None, typer.Option("--margin", help="required gain margin [dB] "
                                                                "(requirements.min_gain_margin_db)")]
ReqFile = Annotated[Path | None, typer.Option("--requirements-file", exists=True, dir_okay=False,
                                              help="requirements object as JSON or YAML")]


def _requirements(margin: float | None, **extra: Any) -> dict[str, Any]:
    req = {k: v for k, v in extra.items() if v is not None}
    if margin is not None:
        req["min_gain_margin_db"] = margin
    return req


@app.command("stiffness")
@c.handle_errors
def stiffness(preset: Preset = None, sets: Sets = None, device_file: DeviceFile = None,
              requirements_file: ReqFile = None, margin: Margin = None,
              passivity: Annotated[bool | None, typer.Option("--passivity/--no-passivity",
                                                             help="require passivity (delayed form)",
                                                             show_default=False)] = None,
              verify: c.Verify = False, local: Local = False, url: Url = DEFAULT_URL, token: Token = None, as_json: AsJson = False) -> None:
    """The stiffest wall K with its damping B that keeps the margin (and passivity, limits)."""
    body = c.assemble({"device": c.device_root(preset, device_file, sets),
                       "requirements": _requirements(margin, passivity=passivity)},
                      sets, files={"requirements": requirements_file})
    with c.client_with_status(Connection(local, url, token), "designing the wall…", as_json) as zw:
        r = zw.design_stiffness(body["device"], body["requirements"], verify=verify)

    def table_rows() -> list[tuple[str, Any, str]]:
        rows = [("status", r.status, ""), ("stiffness K", r.stiffness, "N/m"), ("damping B", r.damping, "N·s/m"),
                ("critical stiffness at B", r.critical_stiffness, "N/m"), ("gain margin", r.gain_margin_db, "dB"),
                ("crossover frequency", r.crossover_frequency, "rad/s"),
                ("linear estimate (eq. 10)", r.linear_estimate, "N/m"), ("B_max", r.max_stable_damping, "N·s/m"),
                ("active constraints", ", ".join(r.active_constraints) or "—", ""),
                ("solver", r.solver.get("return_status", r.solver.get("name")), ""),
                ("elapsed", r.elapsed_ms, "ms")]
        rows += [("reason", r.reason, "")] if r.reason else []
        rows += [(f"sensitivity: {s.parameter}", s.statement, "") for s in r.sensitivities]
        return rows
    c.emit_design(r, as_json, "stiffness design", body["device"], table_rows)


@app.command("inertia")
@c.handle_errors
def inertia(preset: Preset = None, sets: Sets = None, device_file: DeviceFile = None,
            requirements_file: ReqFile = None, margin: Margin = None,
            target_mass: Annotated[float | None, typer.Option(
                "--target-mass", help="apparent mass to reach [kg] (requirements.target_apparent_mass)")] = None,
            verify: c.Verify = False, local: Local = False, url: Url = DEFAULT_URL, token: Token = None, as_json: AsJson = False) -> None:
    """Force-feedforward gain K_f and filter cutoff for the lightest safe feel (chapter §5)."""
    body = c.assemble({"device": c.device_root(preset, device_file, sets),
                       "requirements": _requirements(margin, target_apparent_mass=target_mass)},
                      sets, files={"requirements": requirements_file})
    with c.client_with_status(Connection(local, url, token), "designing the force feedforward…", as_json) as zw:
        r = zw.design_inertia(body["device"], body["requirements"], verify=verify)

    def table_rows() -> list[tuple[str, Any, str]]:
        rows = [("status", r.status, ""), ("objective", r.objective, ""), ("force gain K_f", r.force_gain, ""),
                ("filter cutoff", r.filter_cutoff_hz, "Hz"), ("filter order", r.filter_order, ""),
                ("apparent mass", r.apparent_mass, "kg"), ("critical force gain", r.critical_force_gain, ""),
                ("gain margin", r.gain_margin_db, "dB"), ("crossover frequency", r.crossover_frequency, "rad/s"),
                ("cutoff band", f"{r.cutoff_band_hz[0]:.4g} – {r.cutoff_band_hz[1]:.4g}", "Hz"),
                ("grasp", r.human_source, ""), ("elapsed", r.elapsed_ms, "ms")]
        rows += [("reason", r.reason, "")] if r.reason else []
        rows += [("note", n, "") for n in r.notes]
        return rows
    c.emit_design(r, as_json, "inertia design (force feedforward)", body["device"], table_rows)
