"""The ``zwidth`` command line: the service's answers as tables, JSON for scripts, meaningful exit codes.

Every computing command talks to a server (``--url``, env ZWIDTH_URL, token
``--token``/ZWIDTH_API_TOKEN) or, with ``--local``, runs the service's own code in
this process (:mod:`clients.local`).  Devices come from a preset name, a
``--device-file`` (JSON or YAML) and ``--set device.delay=3e-3`` overrides.
Exit codes are in :mod:`clients.cli_common`.
"""

from __future__ import annotations

from typing import Annotated, Any

import typer
from rich.markup import escape
from rich.progress import Progress
from rich.table import Table
from rich.text import Text

from . import cli_common as c
from .cli_common import (
    DEFAULT_URL,
    AsJson,
    Connection,
    DeviceFile,
    Local,
    Preset,
    SceneFile,
    Sets,
    Token,
    Url,
    emit,
    handle_errors,
    open_client,
    out,
    scene_root,
)
from .cli_design import app as design_app
from .cli_identify import identify as identify_command
from .cli_plot import app as plot_app
from .cli_study import app as study_app
from .robust_cli import robust_app

app = typer.Typer(help="zwidth: the stiffest wall, the lightest feel and the filter that are still safe to render.\n\n"
                       + c.EXIT_CODES_HELP, no_args_is_help=True)
app.add_typer(design_app, name="design")
app.add_typer(plot_app, name="plot")
app.add_typer(robust_app, name="robust")
app.add_typer(study_app, name="study")
app.command("identify")(identify_command)


# ------------------------------------------------------------------------------------------------ presets
@app.command()
@handle_errors
def presets(local: Local = False, url: Url = DEFAULT_URL, token: Token = None, as_json: AsJson = False) -> None:
    """The chapter's devices (Table 2, §4.3) as the service knows them."""
    with open_client(Connection(local, url, token)) as zw:
        devices = zw.presets()

    def human() -> None:
        t = Table(title="presets (SI units; phantom-1.0 is rotary: kg·m², N·m·s/rad, N·m/rad)", title_justify="left")
        t.add_column("preset", no_wrap=True)
        for col in ("mass", "damping", "T [s]", "delay [s]", "cable k_c", "ω_n [rad/s]", "human m_h/b_h/k_h",
                    "T_f [s]"):
            t.add_column(Text(col), justify="left" if col.startswith("human") else "right")
        for name, d in devices.items():
            t.add_row(name, c.fmt(d.mass), c.fmt(d.damping), c.fmt(d.sample_time), c.fmt(d.delay),
                      c.fmt(d.cable.stiffness if d.cable else None),
                      c.fmt(d.cable.natural_frequency if d.cable else None, 5),
                      f"{d.human.mass:g}/{d.human.damping:g}/{d.human.stiffness:g}" if d.human else "—",
                      c.fmt(d.force_sensor.time_constant if d.force_sensor else None))
        out.print(t)
    emit(devices, as_json, human)


# ------------------------------------------------------------------------------------------------ analyze
def _stability_rows(r) -> list[tuple]:
    rows = [("critical stiffness K_cr", r.critical_stiffness, "N/m"),
            ("crossover frequency", r.crossover_frequency, "rad/s"),
            ("virtual damping B", r.damping, "N·s/m")]
    if r.stable is not None:     # a wall was given: its margin, stability and passivity (else they mean nothing)
        rows += [("gain margin", r.gain_margin_db, "dB"), ("stable", r.stable, ""), ("passive", r.passive, "")]
    rows += [("linear estimate (eq. 10)", r.linear_estimate, "N/m"),
            ("linear estimate error", r.linear_error, ""),
            ("rigid-model K_cr", r.rigid_critical_stiffness, "N/m"),
            ("cable mode matters", r.mode_matters, ""),
            ("B_max", r.max_stable_damping, "N·s/m"),
            ("crossovers", len(r.crossovers), ""),
            *([("virtual mass range", f"[{r.mass_range.min}, {r.mass_range.max}]", "kg")]
              if getattr(r, "mass_range", None) is not None else []),
            ("method", r.method, ""), ("error estimate", r.error_estimate, "relative"),
            ("elapsed", r.elapsed_ms, "ms")]
    if r.reason:
        rows.append(("reason", r.reason, ""))
    nl = getattr(r, "nonlinear", None)
    if nl is not None:
        cyc = nl.limit_cycle
        rows += [("passive stiffness limit", nl.passive_stiffness_limit, "N/m"), ("  binding term", nl.binding, ""),
                 ("  covered by the theorem", nl.covered, ""), ("  source", nl.source, ""),
                 ("regime", nl.regime, ""), ("  why", nl.reason, ""),
                 ("limit cycle predicted", cyc.exists, ""), ("  amplitude", cyc.amplitude, "m"),
                 ("  frequency", cyc.frequency_hz, "Hz"), ("  growth threshold", cyc.threshold_amplitude, "m")]
        if nl.verification is not None:
            v = nl.verification
            rows += [("simulation verdict", v.verdict, ""), ("  why", v.reason, ""),
                     ("  measured release", v.measured_state, ""), ("  measured amplitude", v.measured_amplitude, "m"),
                     ("  measured frequency", v.measured_frequency_hz, "Hz")]
    return rows


def _says_no(r) -> bool:
    """The wall is unstable, or no positive stiffness is stable at this damping."""
    return r.stable is False or r.critical_stiffness == 0.0


def parse_velocity_filter(text: str) -> dict:
    """``--velocity-filter``: ``backward_difference``, ``low_pass:F_HZ[:ORDER]`` or ``moving_average:N`` as the
    request's ``controller.velocity_filter`` (the server checks the values: a cutoff below Nyquist, N ≥ 1)."""
    kind, *args = text.strip().split(":")
    try:
        if kind == "backward_difference" and not args:
            return {"kind": kind}
        if kind == "low_pass" and 1 <= len(args) <= 2:
            return {"kind": kind, "cutoff_hz": float(args[0]), "order": int(args[1]) if len(args) == 2 else 1}
        if kind == "moving_average" and len(args) == 1:
            return {"kind": kind, "samples": int(args[0])}
    except ValueError:
        pass
    raise c.usage_error(f"--velocity-filter {text!r}: expected backward_difference, low_pass:F_HZ[:ORDER] (e.g. "
                        "low_pass:50:1) or moving_average:N")


@app.command()
@handle_errors
def analyze(preset: Annotated[str | None, typer.Argument(help="preset name, or 'all' for every preset",
                                                         show_default=False)] = None,
            sets: Sets = None, device_file: DeviceFile = None,
            stiffness: Annotated[float | None, typer.Option(help="K of the wall to check [N/m]")] = None,
            damping: Annotated[float | None, typer.Option(help="B of the wall [N·s/m] (K_cr is for this B)")] = None,
            method: Annotated[str | None, typer.Option(help="linear | grid | exact | reference")] = None,
            grid_points: Annotated[int | None, typer.Option(help="frequencies for method=grid")] = None,
            encoder: Annotated[float | None, typer.Option(
                help="encoder resolution q [m per count] (device.encoder_resolution)")] = None,
            coulomb: Annotated[float | None, typer.Option(
                help="Coulomb friction f_c [N] on the motor side (device.coulomb_friction)")] = None,
            velocity_filter: Annotated[str | None, typer.Option(
                help="the velocity the damper sees: backward_difference | low_pass:F_HZ[:ORDER] | "
                     "moving_average:N")] = None,
            virtual_mass: Annotated[float | None, typer.Option(help="virtual mass M of the wall [kg]")] = None,
            verify: c.Verify = False, local: Local = False, url: Url = DEFAULT_URL, token: Token = None, as_json: AsJson = False) -> None:
    """Critical stiffness K_cr(B), every crossover, margin and passivity (POST /v1/analysis/stability).

    With --encoder or --coulomb, also the passive stiffness limit (Abbott & Okamura), the predicted limit
    cycle and the regime.  Exit 1 when the given wall is unstable or no K > 0 is stable.
    """
    nonlinear = {k: v for k, v in (("encoder_resolution", encoder), ("coulomb_friction", coulomb)) if v is not None}
    controller = None
    rendered = velocity_filter is not None or virtual_mass is not None
    if stiffness is not None or damping is not None or rendered:
        if stiffness is None and not rendered:
            raise c.usage_error("--damping needs --stiffness (the wall is K + B(1 − z⁻¹)/T); without a wall, "
                                "K_cr is reported at B = 0")
        controller = {**({"stiffness": stiffness} if stiffness is not None else {}),
                      **({"damping": damping} if damping is not None else {}),
                      **({"mass": virtual_mass} if virtual_mass is not None else {}),
                      **({"velocity_filter": parse_velocity_filter(velocity_filter)} if velocity_filter else {})}
    with open_client(Connection(local, url, token)) as zw:
        if preset == "all":
            names = list(zw.presets())
            results = {}
            with Progress(console=c.err, transient=True, disable=as_json) as bar:
                task = bar.add_task("analysing presets", total=len(names))
                for name in names:
                    body = c.assemble({"device": {"preset": name, **nonlinear}, "controller": controller}, sets)
                    results[name] = zw.stability(body["device"], body.get("controller"), method=method,
                                                 grid_points=grid_points, verify=verify)
                    bar.advance(task)
        else:
            body = c.assemble({"device": {**c.device_root(preset, device_file, sets), **nonlinear},
                               "controller": controller}, sets)
            with c.progress_status("analysing…", as_json):
                result = zw.stability(body["device"], body.get("controller"), method=method, grid_points=grid_points,
                                      verify=verify)
            results = {preset or "device": result}

    def human() -> None:
        if len(results) == 1 and preset != "all":
            r = next(iter(results.values()))
            out.print(c.table(f"stability of {preset or 'the device'}",
                              _stability_rows(r) + c.verification_rows(r.verification),
                              device=body["device"]))
            return
        rotary = sorted(n for n in results if n in c.ROTARY_PRESETS)
        note = f" ({', '.join(rotary)} rotary: N·m/rad)" if rotary else ""
        t = Table(title=f"stability of every preset{note}", title_justify="left")
        t.add_column("preset", no_wrap=True)
        for col in ("K_cr [N/m]", "ω_cr [rad/s]", "rigid K_cr [N/m]", "eq. 10 [N/m]", "margin [dB]", "stable"):
            t.add_column(Text(col), justify="right")
        for name, r in results.items():
            t.add_row(name, c.fmt(r.critical_stiffness), c.fmt(r.crossover_frequency, 5),
                      c.fmt(r.rigid_critical_stiffness), c.fmt(r.linear_estimate), c.fmt(r.gain_margin_db, 4),
                      c.fmt(r.stable))
        out.print(t)

    emit(results if preset == "all" else next(iter(results.values())), as_json, human)
    if any(_says_no(r) or (r.verification is not None and r.verification.verdict == "contradicted")
           for r in results.values()):
        raise typer.Exit(c.EXIT_NO)


# ------------------------------------------------------------------------------------------------ boundary
@app.command()
@handle_errors
def boundary(preset: Preset = None, sets: Sets = None, device_file: DeviceFile = None,
             damping_max: Annotated[float | None, typer.Option(help="largest B [N·s/m]; default B_max")] = None,
             points: Annotated[int | None, typer.Option(help="values of B on the curve")] = None,
             velocity_filter: Annotated[str | None, typer.Option(
                 help="the velocity the damper sees: backward_difference | low_pass:F_HZ[:ORDER] | "
                      "moving_average:N")] = None,
             virtual_mass: Annotated[float | None, typer.Option(help="virtual mass M of the walls [kg]")] = None,
             verify: c.Verify = False, local: Local = False, url: Url = DEFAULT_URL, token: Token = None,
             as_json: AsJson = False) -> None:
    """The stability boundary K_cr(B) from B = 0 to B_max and its optimum (POST /v1/analysis/boundary), for
    today's wall or the rendered one (--velocity-filter, --virtual-mass)."""
    controller = None
    if velocity_filter is not None or virtual_mass is not None:
        controller = {**({"mass": virtual_mass} if virtual_mass is not None else {}),
                      **({"velocity_filter": parse_velocity_filter(velocity_filter)} if velocity_filter else {})}
    body = c.assemble({"device": c.device_root(preset, device_file, sets), "controller": controller}, sets)
    with c.client_with_status(Connection(local, url, token), "computing the boundary…", as_json) as zw:
        r = zw.boundary(body["device"], body.get("controller"), damping_max=damping_max, points=points, verify=verify)

    def human() -> None:
        o = r.optimum
        rows: list[tuple] = [("largest stable damping B_max", r.max_stable_damping, "N·s/m"),
                ("optimum damping", o.damping, "N·s/m"), ("best K_cr", o.critical_stiffness, "N/m"),
                ("  its crossover", o.crossover_frequency, "rad/s"), ("points", len(r.points), ""),
                ("method", r.method, ""), ("elapsed", r.elapsed_ms, "ms")]
        out.print(c.table(f"stability boundary of {preset or 'the device'}", rows + c.verification_rows(r.verification),
                          device=body["device"]))
        t = Table(title="K_cr(B)", title_justify="left")
        for col in ("B [N·s/m]", "K_cr [N/m]", "ω_cr [rad/s]"):
            t.add_column(Text(col), justify="right")
        for p in r.points:
            t.add_row(c.fmt(p.damping), c.fmt(p.critical_stiffness), c.fmt(p.crossover_frequency, 5))
        out.print(t)

    emit(r, as_json, human)
    c.exit_if_contradicted(r.verification)


# ------------------------------------------------------------------------------------------------ feedforward
@app.command()
@handle_errors
def feedforward(preset: Preset = None, sets: Sets = None, device_file: DeviceFile = None,
                cutoff_hz: Annotated[float | None, typer.Option(help="Butterworth D(z) cutoff [Hz]")] = None,
                order: Annotated[int | None, typer.Option(help="Butterworth order")] = None,
                verify: c.Verify = False, local: Local = False, url: Url = DEFAULT_URL, token: Token = None, as_json: AsJson = False) -> None:
    """Critical force-feedforward gain K_f,cr (chapter §5; POST /v1/analysis/force-feedforward)."""
    filt = None
    if cutoff_hz is not None:
        filt = {"cutoff_hz": cutoff_hz, **({"order": order} if order is not None else {})}
    elif order is not None:
        raise c.usage_error("--order needs --cutoff-hz")
    body = c.assemble({"device": c.device_root(preset, device_file, sets), "filter": filt}, sets)
    with c.client_with_status(Connection(local, url, token), "analysing the force feedforward…", as_json) as zw:
        r = zw.force_feedforward(body["device"], body.get("filter"), verify=verify)

    def human() -> None:
        rows = [("critical force gain K_f,cr", r.critical_force_gain, ""),
                ("crossover frequency", r.crossover_frequency, "rad/s"),
                ("worst-case force gain (eq. 33)", r.worst_case_force_gain, ""),
                ("apparent mass at K_f,cr", r.apparent_mass_at_critical, "kg"), ("model", r.model, ""),
                ("rigid-model K_f,cr", r.rigid_critical_force_gain, ""), ("grasp", r.human_source, ""),
                ("method", r.method, ""), ("elapsed", r.elapsed_ms, "ms")]
        rows += [("reason", r.reason, "")] if r.reason else []
        rows += [("note", n, "") for n in r.notes]
        rows += c.verification_rows(r.verification)
        out.print(c.table("force feedforward", rows, device=body["device"]))
    emit(r, as_json, human)
    c.exit_if_contradicted(r.verification)


# ------------------------------------------------------------------------------------------------ workspace
@app.command()
@handle_errors
def workspace(preset: Annotated[str, typer.Argument(help="kinematic preset (planar-2link, phantom-premium-1.5), "
                                                        "or a URDF file's path")],
              end_effector: Annotated[str | None, typer.Option(help="end-effector frame (with a URDF file)")] = None,
              poses: Annotated[int, typer.Option(help="Latin-hypercube poses over the joint limits")] = 100,
              seed: Annotated[int, typer.Option(help="the poses' seed")] = 0,
              normal: Annotated[str | None, typer.Option(help="a wall normal 'nx,ny,nz' (default: each pose's "
                                                               "worst)")] = None,
              sample_time: Annotated[float, typer.Option(help="T [s]")] = 0.001,
              delay: Annotated[float, typer.Option(help="t_d [s]")] = 0.0,
              damping: Annotated[float | None, typer.Option(help="B of the wall [N·s/m]")] = None,
              local: Local = False, url: Url = DEFAULT_URL, token: Token = None, as_json: AsJson = False) -> None:
    """K_cr of the wall over a multi-DOF device's workspace (POST /v1/analysis/workspace)."""
    from pathlib import Path

    path = Path(preset)
    if path.is_file():
        if end_effector is None:
            raise c.usage_error("a URDF file needs --end-effector")
        kin: dict = {"urdf": path.read_text(), "end_effector": end_effector}
    else:
        kin = {"preset": preset, **({"end_effector": end_effector} if end_effector else {})}
    normals: list[list[float]] | str = "worst"
    if normal is not None:
        try:
            normals = [[float(x) for x in normal.split(",")]]
        except ValueError:
            raise c.usage_error("--normal is three numbers 'nx,ny,nz'") from None
    controller = {"stiffness": 1.0, "damping": damping} if damping is not None else None
    device = {"sample_time": sample_time, "delay": delay, "kinematics": kin}
    with c.client_with_status(Connection(local, url, token), "mapping the workspace…", as_json) as zw:
        r = zw.workspace(device, {"latin_hypercube": {"samples": poses, "seed": seed}}, normals, controller)

    def human() -> None:
        w = r.worst
        rows = [("minimum K_cr", r.minimum_critical_stiffness, "N/m"),
                ("at pose", ", ".join(f"{x:.4g}" for x in w.pose), "rad"),
                ("along normal", ", ".join(f"{x:.4g}" for x in w.normal), ""),
                ("effective mass there", w.effective_mass, "kg"), ("effective damping there", w.effective_damping,
                                                                   "N·s/m"),
                ("1-DOF approximation's K_cr", w.one_dof_critical_stiffness, "N/m"),
                ("points", len(r.points), ""), ("elapsed", r.elapsed_ms, "ms"), ("note", r.note, "")]
        out.print(c.table(f"workspace of {preset}", rows))
    emit(r, as_json, human)


# ------------------------------------------------------------------------------------------------ simulate
Experiment = Annotated[str | None, typer.Option(help="release | push | relay")]
Duration = Annotated[float | None, typer.Option(help="simulated time [s]")]
WallK = Annotated[float | None, typer.Option("--stiffness", help="wall K [N/m]")]
WallB = Annotated[float | None, typer.Option("--damping", help="wall B [N·s/m]")]
Position = Annotated[float | None, typer.Option(help="initial position [m] (penetration, positive inwards)")]
Velocity = Annotated[float | None, typer.Option(help="initial velocity [m/s]")]
RelayAmp = Annotated[float | None, typer.Option(help="relay force amplitude [N] (experiment relay)")]
Effect = Annotated[list[str] | None, typer.Option(
    "--effect", help="an effect taken from the device: delay, cable_mode, human, force_sensor_filter "
                     "(others with --set scene.effects.quantization.resolution=1e-5 …)")]


@app.command()
@handle_errors
def simulate(preset: Preset = None, sets: Sets = None, device_file: DeviceFile = None, scene_file: SceneFile = None,
             experiment: Experiment = None, duration: Duration = None, stiffness: WallK = None, damping: WallB = None,
             position: Position = None, velocity: Velocity = None, relay_amplitude: RelayAmp = None,
             effect: Effect = None, local: Local = False, url: Url = DEFAULT_URL, token: Token = None,
             as_json: AsJson = False) -> None:
    """Simulate a scene on the device (POST /v1/simulate) and give its verdict.

    Exit 1 when the verdict is unstable (poles outside the unit circle, diverged or growing) or undetermined
    (the reason says why and what would decide it).
    """
    body = c.assemble({"device": c.device_root(preset, device_file, sets),
                       "scene": scene_root(experiment, duration, stiffness, damping, position, velocity,
                                           relay_amplitude, effect)},
                      sets, files={"scene": scene_file})
    with open_client(Connection(local, url, token)) as zw, c.progress_status("simulating…", as_json):
        r = zw.simulate(body["device"], body["scene"])

    def human() -> None:
        v = r.verdict
        rows: list[tuple[str, Any, str]] = [("verdict", v.state, ""), ("decided by", v.decided_by, ""),
                                            ("why", v.reason, "")]
        if v.disagreement:
            rows += [("disagreement", v.disagreement, "")]
        if v.poles is not None:
            p = v.poles
            rows += [("spectral radius, its ω" + (" (linear part)" if p.linearised else ""),
                      f"{p.dominant_pole.modulus:.9g}, {p.dominant_pole.frequency:.6g} rad/s", "")]
        elif v.poles_note:
            rows += [("no poles", v.poles_note, "")]
        if v.measured is not None and v.decided_by != "trajectory":
            rows += [("measured", f"{v.measured.state}: {v.measured.reason}", "")]
        rows += [("oscillation frequency", v.frequency, "rad/s"),
                ("amplitude at the end", v.amplitude, "m"), ("growth rate", v.growth_rate, "1/s"),
                ("diverged at", r.diverged_at, "s"), ("energy generated", r.energy_generated, "J"),
                ("effects simulated", ", ".join(r.effects_simulated), ""),
                ("left out", ", ".join(r.not_simulated) or "—", ""), ("method", r.method, ""),
                ("samples run", r.samples_run, ""), ("elapsed", r.elapsed_ms, "ms")]
        if r.relay is not None:
            s = r.relay.settled
            rows += [("relay K_u", s.ultimate_gain if s else None, "N/m"),
                     ("relay ω", s.frequency if s else None, "rad/s"),
                     ("exact K_cr of the loop", r.relay.critical_stiffness, "N/m"),
                     ("K_u error vs K_cr", r.relay.ultimate_gain_error, "")]
        out.print(c.table("simulation", rows, device=body["device"]))

    emit(r, as_json, human)
    if r.verdict.state in ("unstable", "undetermined"):
        if r.verdict.state == "undetermined" and not as_json:
            c.err.print(f"[bold yellow]undetermined:[/] {escape(r.verdict.reason)}")
        raise typer.Exit(c.EXIT_NO)


# ------------------------------------------------------------------------------------------------ serve, bench
def compute_workers_per_server(servers: int, cpus: int | None) -> int:
    """Compute processes per uvicorn worker when ``servers`` of them share ``cpus`` cores (at least 1): with
    2 cores and ``--workers 2``, one each (the exact rigid analysis runs inline, in the server process)."""
    return max(1, (cpus or 1) // servers)


@app.command()
def serve(host: str = typer.Option("127.0.0.1", help="interface to bind; anything but loopback needs a token "
                                                   "(ZWIDTH_API_TOKEN or ZWIDTH_API_TOKEN_FILE)"),
          port: int = typer.Option(8000, min=1, max=65535, help="TCP port"),
          workers: int = typer.Option(1, min=1, help="uvicorn worker processes, each with its own compute pool "
                                                     "(of cores // workers processes unless ZWIDTH_COMPUTE_WORKERS "
                                                     "is set)"),
          log_level: str = typer.Option("info", help="log level (logs are JSON lines on stderr)"),
          insecure_no_auth: bool = typer.Option(False, "--insecure-no-auth",
                                                help="serve a non-loopback address without a token (also "
                                                     "ZWIDTH_ALLOW_NO_AUTH=1); refused otherwise")) -> None:
    """Serve the HTTP API with uvicorn (settings from ZWIDTH_* environment variables).

    Refuses (exit 2, saying why) to bind a non-loopback address without a token, and to start when the default
    study store under HOME cannot be created.  The store is created and migrated once, before the workers."""
    import os

    with c.full_install("zwidth serve"):
        import uvicorn

        from service.logs import uvicorn_log_config
        from service.settings import Settings
        from service.startup import StartRefused, check_exposure, prepare_store

    try:
        settings = Settings()
        warning = check_exposure(host, settings.token, insecure_no_auth)
        shown, store_warning = prepare_store(settings)
    except (StartRefused, ValueError) as exc:   # ValueError: a setting (e.g. HOME unset for the default store)
        c.err.print(f"[bold red]zwidth serve: {escape(str(exc))}[/]")
        raise typer.Exit(2) from None
    for w in (warning, store_warning):
        if w:
            c.err.print(f"[bold yellow]{escape(w)}[/]")
    c.err.print(f"zwidth: studies are stored in {escape(shown)} (ZWIDTH_DATABASE_URL to change)")
    if workers > 1:   # each uvicorn worker has its own compute pool: share the cores out, unless told otherwise
        os.environ.setdefault("ZWIDTH_COMPUTE_WORKERS", str(compute_workers_per_server(workers, os.cpu_count())))

    uvicorn.run("service.app:app", host=host, port=port, workers=workers, log_level=log_level,
                log_config=uvicorn_log_config(log_level), access_log=False, proxy_headers=False)


bench_app = typer.Typer(help="Benchmarks that write their tables into docs/ (from a source checkout of zwidth: "
                             "bench/ and tests/ are not installed with the package).", no_args_is_help=True)
app.add_typer(bench_app, name="bench")


def _bench_module(name: str):
    """bench/<name>.py of a source checkout; a usage error (exit 2) saying so in an installed copy."""
    import importlib

    try:
        return importlib.import_module(f"bench.{name}")
    except ImportError as exc:
        raise c.usage_error(f"zwidth bench runs from a source checkout of zwidth (bench/ and tests/ are not "
                            f"installed with the package): run `python -m bench.{name}` in the checkout "
                            f"({exc})") from None


@bench_app.command("accuracy")
def bench_accuracy(quick: bool = typer.Option(False, help="the 5-case version"),
                   repeats: int = typer.Option(7, min=1),
                   out: str = typer.Option("docs/accuracy.md")) -> None:
    """What accuracy costs in time: the ladder and python-control on one suite (docs/accuracy.md, .png)."""
    _bench_module("accuracy_vs_time").main((["--quick"] if quick else []) + ["--repeats", str(repeats), "--out", out])


@bench_app.command("core")
def bench_core(repeats: int = typer.Option(30, min=1), out: str = typer.Option("docs/bench_core.md")) -> None:
    """Exact K_cr against python-control's stability_margins (docs/bench_core.md)."""
    _bench_module("bench_core").main(["--repeats", str(repeats), "--out", out])


if __name__ == "__main__":  # pragma: no cover
    app()
