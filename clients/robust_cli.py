"""``zwidth robust stiffness|inertia|hardware|plot``: robust and inverse (hardware) design (issue 12).

Every call goes through :class:`clients.ZwidthClient` (``--local`` runs the service's own app in this
process), with the exit codes of every ``zwidth`` command (clients/cli_common.py): 0 optimal, 1 the
design is infeasible or failed, 2 usage or a 422 naming the field, 3 the service could not answer.

    zwidth robust stiffness lhifam --rigid --range device.mass=4:7 --range device.delay=0:0.002
    zwidth robust inertia lhifam --rigid --range device.human.mass=0.5:3 --target-mass 1.0
    zwidth robust hardware lhifam --rigid --free delay --stiffness 2e5 --force-gain 5   # optimal
    zwidth robust stiffness lhifam --rigid --range device.mass=4:7 --verify   # checked at every corner
    zwidth robust hardware lhifam --free delay --stiffness 2e5 --force-gain 5   # infeasible: the sampling binds
    zwidth robust plot lhifam --rigid --range device.mass=4:7 --range device.delay=0:0.002 -o slice.png
    zwidth robust plot lhifam --rigid --free delay --stiffness 2e5 -o tradeoff.svg
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from . import cli_common as c
from .cli_common import DEFAULT_URL, AsJson, Connection, DeviceFile, Local, Preset, Sets, Token, Url, out

__all__ = ["robust_app", "parse_range"]

robust_app = typer.Typer(help="Robust designs over parameter ranges, and the hardware a target needs.",
                         no_args_is_help=True)

Ranges = Annotated[list[str] | None, typer.Option(
    "--range", "-r", metavar="PATH=MIN:MAX",
    help="an uncertain device parameter and its range, repeatable (device.mass=4:7, device.delay=0:0.002, "
         "device.cable.stiffness=5e4:1e5, device.human.mass=0.5:3 …)")]
Rigid = Annotated[bool, typer.Option("--rigid", help="the rigid model of the preset (device.cable=null)")]
Margin = Annotated[float | None, typer.Option("--margin", help="required gain margin [dB]")]
Free = Annotated[str | None, typer.Option("--free", help="hardware design: the free parameter (sample_time | "
                                                         "delay | damping | mass | cable.stiffness | encoder_resolution | coulomb_friction)")]


def parse_range(text: str) -> tuple[str, dict[str, float]]:
    """'device.mass=4:7' → ('device.mass', {'min': 4.0, 'max': 7.0})."""
    path, _, rng = text.partition("=")
    lo, _, hi = rng.partition(":")
    try:
        if not path.strip() or not lo or not hi:
            raise ValueError
        return path.strip(), {"min": float(lo), "max": float(hi)}
    except ValueError:
        raise c.usage_error(f"--range {text!r}: expected PATH=MIN:MAX, e.g. device.mass=4:7") from None


def _device(preset: str | None, device_file: Path | None, sets: list[str] | None, rigid: bool) -> dict[str, Any]:
    device = c.device_root(preset, device_file, sets)
    if rigid:
        device["cable"] = None
    return device


def _body(preset, device_file, sets, rigid, ranges, margin, **extra) -> dict[str, Any]:
    if not ranges:
        raise c.usage_error("give at least one --range PATH=MIN:MAX (the uncertain parameters)")
    req: dict[str, Any] = {k: v for k, v in extra.items() if v is not None}
    if margin is not None:
        req["min_gain_margin_db"] = margin
    req["uncertainty"] = dict(parse_range(r) for r in ranges)
    return c.assemble({"device": _device(preset, device_file, sets, rigid), "requirements": req}, sets)


def _worst(worst: dict[str, Any] | None) -> str:
    if not worst:
        return "—"
    values = worst.get("device", {})
    return ", ".join(f"{k} = {v:.6g}" for k, v in values.items()) or "the nominal device"


@robust_app.command("stiffness")
@c.handle_errors
def stiffness(preset: Preset = None, sets: Sets = None, device_file: DeviceFile = None, rigid: Rigid = False,
              ranges: Ranges = None, margin: Margin = None,
              passivity: Annotated[bool | None, typer.Option("--passivity/--no-passivity",
                                                             help="also passive for every device of the box",
                                                             show_default=False)] = None,
              verify: c.Verify = False, local: Local = False, url: Url = DEFAULT_URL, token: Token = None,
              as_json: AsJson = False) -> None:
    """The stiffest wall (K, B) whose gain margin holds for every device of the box."""
    body = _body(preset, device_file, sets, rigid, ranges, margin, passivity=passivity)
    with c.client_with_status(Connection(local, url, token), "designing the robust wall…", as_json) as zw:
        r = zw.design_stiffness(body["device"], body["requirements"], verify=verify)

    def table_rows() -> list[tuple[str, Any, str]]:
        w = r.worst_case
        rows = [("status", r.status, ""), ("stiffness K", r.stiffness, "N/m"), ("damping B", r.damping, "N·s/m"),
                ("worst device", _worst(w.model_dump() if w else None), ""),
                ("worst-case margin", w.gain_margin_db if w else None, "dB"),
                ("nominal margin", r.nominal_gain_margin_db, "dB"),
                ("scenarios", len(r.scenarios or []), ""), ("iterations", r.iterations, ""),
                ("exact analyses", r.evaluations, ""), ("elapsed", r.elapsed_ms, "ms")]
        rows += [("reason", r.reason, "")] if r.reason else []
        rows += [("ignored paths", ", ".join(r.ignored_paths), "")] if r.ignored_paths else []
        return rows
    c.emit_design(r, as_json, "robust stiffness design", body["device"], table_rows)


@robust_app.command("inertia")
@c.handle_errors
def inertia(preset: Preset = None, sets: Sets = None, device_file: DeviceFile = None, rigid: Rigid = False,
            ranges: Ranges = None, margin: Margin = None,
            target_mass: Annotated[float | None, typer.Option(
                "--target-mass", help="apparent mass to reach [kg] (requirements.target_apparent_mass)")] = None,
            verify: c.Verify = False, local: Local = False, url: Url = DEFAULT_URL, token: Token = None,
            as_json: AsJson = False) -> None:
    """Force-feedforward gain and filter cutoff whose margin holds for every device of the box."""
    body = _body(preset, device_file, sets, rigid, ranges, margin, target_apparent_mass=target_mass)
    with c.client_with_status(Connection(local, url, token), "designing the robust feedforward…", as_json) as zw:
        r = zw.design_inertia(body["device"], body["requirements"], verify=verify)

    def table_rows() -> list[tuple[str, Any, str]]:
        w = r.worst_case or {}
        mass = r.apparent_mass_range
        rows = [("status", r.status, ""), ("force gain K_f", r.force_gain, ""),
                ("filter cutoff", r.filter_cutoff_hz, "Hz"), ("apparent mass (nominal)", r.apparent_mass, "kg"),
                ("apparent mass over the box", f"{mass[0]:.4g} – {mass[1]:.4g}" if mass else None, "kg"),
                ("worst device", _worst(w), ""), ("worst-case margin", w.get("gain_margin_db"), "dB"),
                ("nominal margin", r.nominal_gain_margin_db, "dB"), ("scenarios", len(r.scenarios or []), ""),
                ("iterations", r.iterations, ""), ("elapsed", r.elapsed_ms, "ms")]
        rows += [("reason", r.reason, "")] if r.reason else []
        rows += [("note", n, "") for n in r.notes]
        return rows
    c.emit_design(r, as_json, "robust inertia design (force feedforward)", body["device"], table_rows)


def _targets(stiffness, force_gain, apparent_mass, margin, max_damping, points) -> dict[str, Any]:
    return {k: v for k, v in (("stiffness", stiffness), ("force_gain", force_gain),
                              ("apparent_mass", apparent_mass), ("min_gain_margin_db", margin),
                              ("max_damping", max_damping), ("points", points)) if v is not None}


TargetK = Annotated[float | None, typer.Option("--stiffness", help="target wall stiffness K [N/m]")]
TargetKf = Annotated[float | None, typer.Option("--force-gain", help="target force-feedforward gain K_f")]
TargetM = Annotated[float | None, typer.Option("--apparent-mass", help="target apparent mass m/(1 + K_f) [kg]")]
MaxB = Annotated[float | None, typer.Option("--max-damping", help="cap on the virtual damping B [N·s/m]")]
Points = Annotated[int | None, typer.Option("--points", help="points of the trade-off curve")]
Scan = Annotated[str | None, typer.Option("--scan", help="scan exactly MIN:MAX of the free parameter [SI] "
                                                         "(default: value/30 … value·30, widened as needed)")]


def _scan_range(scan: str | None) -> tuple[float, float] | None:
    if scan is None:
        return None
    lo, sep, hi = scan.partition(":")
    try:
        if not sep:
            raise ValueError
        return float(lo), float(hi)
    except ValueError:
        raise c.usage_error(f"--scan: expected MIN:MAX, got {scan!r}") from None


@robust_app.command("hardware")
@c.handle_errors
def hardware(preset: Preset = None, sets: Sets = None, device_file: DeviceFile = None, rigid: Rigid = False,
             free: Free = None, stiffness: TargetK = None, force_gain: TargetKf = None, apparent_mass: TargetM = None,
             margin: Margin = None, max_damping: MaxB = None, points: Points = None, scan: Scan = None,
             verify: c.Verify = False, local: Local = False, url: Url = DEFAULT_URL, token: Token = None,
             as_json: AsJson = False) -> None:
    """The loosest value of one hardware parameter that still renders the target(s)."""
    value_range = _scan_range(scan)
    if free is None:
        raise c.usage_error("--free is required: sample_time | delay | damping | mass | cable.stiffness | "
                            "encoder_resolution | coulomb_friction")
    body = c.assemble({"device": _device(preset, device_file, sets, rigid)}, sets)
    with c.client_with_status(Connection(local, url, token), "scanning the hardware…", as_json) as zw:
        r = zw.design_hardware(body["device"], free, **_targets(stiffness, force_gain, apparent_mass, margin,
                                                                 max_damping, points), value_range=value_range,
                               verify=verify)

    def table_rows() -> list[tuple[str, Any, str]]:
        ctl = r.controller
        rows = [("status", r.status, ""), (f"loosest {r.free} ({r.direction})", r.value, ""),
                ("bounded in the scanned range", r.bounded, ""),
                ("feasible set", "; ".join(f"[{a:.6g}, {b:.6g}]" for a, b in r.intervals) or "—", ""),
                ("limiting target", r.limiting_target, ""), ("limiting effect", r.limiting_effect, ""),
                ("scanned range", r.range_source, "")]
        if ctl is not None:
            rows += [("controller K", ctl.stiffness, "N/m"), ("controller B", ctl.damping, "N·s/m"),
                     ("wall margin", ctl.gain_margin_db, "dB"), ("force gain K_f", ctl.force_gain, ""),
                     ("filter cutoff", ctl.filter_cutoff_hz, "Hz"),
                     ("force-gain margin", ctl.force_gain_margin_db, "dB")]
        rows += [("best achievable K", r.best_achievable_stiffness, "N/m"),
                 ("best achievable K_f", r.best_achievable_force_gain, ""), ("elapsed", r.elapsed_ms, "ms")]
        rows += [("reason", r.reason, "")] if r.reason else []
        rows += [("note", r.note, "")] if r.note else []
        return rows
    c.emit_design(r, as_json, "hardware design", body["device"], table_rows)


@robust_app.command("plot")
@c.handle_errors
def plot(preset: Preset = None, sets: Sets = None, device_file: DeviceFile = None, rigid: Rigid = False,
         ranges: Ranges = None, margin: Margin = None, free: Free = None, stiffness: TargetK = None,
         force_gain: TargetKf = None, apparent_mass: TargetM = None, max_damping: MaxB = None,
         points: Points = None,
         x: Annotated[str | None, typer.Option(help="robust slice: the uncertain path on the x axis")] = None,
         y: Annotated[str | None, typer.Option(help="robust slice: the uncertain path on the y axis")] = None,
         out_file: Annotated[Path, typer.Option("--out", "-o", help=".png or .svg")] = Path("robust.png"),
         local: Local = False, url: Url = DEFAULT_URL, token: Token = None) -> None:
    """With --range: the robust wall's margin over a slice of the box; with --free: the hardware trade-off."""
    fmt = out_file.suffix.lower()[1:]
    if fmt not in ("png", "svg"):
        raise c.usage_error(f"--out {out_file}: the file must end in .png or .svg")
    if (free is None) == (not ranges):
        raise c.usage_error("give either --range … (the robust slice) or --free … (the hardware trade-off)")
    with c.open_client(Connection(local, url, token)) as zw, c.progress_status("drawing…", False):
        if free is None:
            body = _body(preset, device_file, sets, rigid, ranges, margin, max_damping=max_damping)
            image = zw.plot_robust(body["device"], body["requirements"], x=x, y=y, points=points, format=fmt)
        else:
            body = c.assemble({"device": _device(preset, device_file, sets, rigid)}, sets)
            image = zw.plot_hardware(body["device"], free, format=fmt,
                                     **_targets(stiffness, force_gain, apparent_mass, margin, max_damping, points))
    image.save(str(out_file))
    out.print(f"wrote {out_file} ({image.media_type}, {len(image.content):,} bytes)", markup=False)
