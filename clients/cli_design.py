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


def _workspace(kinematics: str | None, poses: int, seed: int, verify_factor: int | None) -> dict[str, Any] | None:
    """requirements.workspace from the flags: a kinematic preset (or a URDF file's path with its end effector as
    'path:frame'), a Latin hypercube of poses, each pose's worst normal."""
    if kinematics is None:
        return None
    path, _, frame = kinematics.rpartition(":")
    if path and Path(path).is_file():
        kin: dict[str, Any] = {"urdf": Path(path).read_text(), "end_effector": frame}
    elif Path(kinematics).is_file():
        raise c.usage_error("a URDF file is given as --workspace 'path:end_effector_frame'")
    else:
        kin = {"preset": kinematics}
    out: dict[str, Any] = {"kinematics": kin, "poses": {"latin_hypercube": {"samples": poses, "seed": seed}},
                           "normals": "worst"}
    if verify_factor is not None:
        out["verify_factor"] = verify_factor
    return out


@app.command("stiffness")
@c.handle_errors
def stiffness(preset: Preset = None, sets: Sets = None, device_file: DeviceFile = None,
              requirements_file: ReqFile = None, margin: Margin = None,
              passivity: Annotated[bool | None, typer.Option("--passivity/--no-passivity",
                                                             help="require passivity (delayed form)",
                                                             show_default=False)] = None,
              workspace: Annotated[str | None, typer.Option(
                  "--workspace", help="design over a multi-DOF device's workspace (requirements.workspace): a "
                                      "kinematic preset (planar-2link, phantom-premium-1.5) or 'urdf_path:frame'; "
                                      "the device gives T and t_d")] = None,
              workspace_poses: Annotated[int, typer.Option(help="--workspace: Latin-hypercube design poses")] = 20,
              workspace_seed: Annotated[int, typer.Option(help="--workspace: the poses' seed")] = 0,
              verify_factor: Annotated[int | None, typer.Option(
                  help="--workspace: the verification set is this many times the design poses")] = None,
              verify: c.Verify = False, local: Local = False, url: Url = DEFAULT_URL, token: Token = None, as_json: AsJson = False) -> None:
    """The stiffest wall K with its damping B that keeps the margin (and passivity, limits); with --workspace,
    one (K, B) safe at every pose and normal of a multi-DOF device."""
    body = c.assemble({"device": c.device_root(preset, device_file, sets),
                       "requirements": _requirements(margin, passivity=passivity,
                                                     workspace=_workspace(workspace, workspace_poses,
                                                                          workspace_seed, verify_factor))},
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
        ws = getattr(r, "workspace", None)
        if ws is not None:
            rows += [("workspace: worst cases", len(ws.worst_cases), ""), ("workspace: exchanges", ws.exchanges, ""),
                     ("workspace: verification poses", ws.verification_poses, ""),
                     ("workspace: verification margin", ws.verification_margin, "")]
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
