"""What every ``zwidth`` command shares: options, request assembly, the client, output and exit codes.

Exit codes (also in ``zwidth --help`` and docs/clients.md):

====  =====================================================================================
0     the command worked and the answer is "yes" (or is plain information)
1     the answer is "no": a design is infeasible, failed or unsafe, the given wall is unstable or
      no positive stiffness is stable, a simulation is unstable or undetermined (its verdict
      does not show the wall stable)
2     usage or validation error: a bad option, an unknown preset, a 422 from the service
      (the message names the field)
3     the service could not answer: connection refused or timed out (after retries),
      401/413/5xx, or an answer that does not match this client's contract
====  =====================================================================================
"""

from __future__ import annotations

import contextlib
import functools
import json
import sys
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Annotated, Any, TypeVar

import typer
from pydantic import BaseModel
from rich.console import Console
from rich.markup import escape
from rich.table import Table
from rich.text import Text

from .client import DEFAULT_URL, ZwidthClient
from .errors import APIError, ProtocolError, TransportError, ValidationFailed, ZwidthError

__all__ = ["EXIT_OK", "EXIT_NO", "EXIT_USAGE", "EXIT_SERVICE", "EXIT_CODES_HELP", "Local", "Url",
           "Token", "AsJson", "Preset", "Sets", "DeviceFile", "SceneFile", "scene_root", "client_with_status", "Connection", "open_client", "handle_errors",
           "assemble", "emit", "table", "fmt", "out", "err", "usage_error", "progress_status", "exit_unless_optimal"]

EXIT_OK, EXIT_NO, EXIT_USAGE, EXIT_SERVICE = 0, 1, 2, 3
EXIT_CODES_HELP = ("Exit codes: 0 ok; 1 the answer is no (design infeasible, failed or unsafe, wall unstable, "
                   "simulation unstable or undetermined); 2 usage or validation error (422 names the field); 3 service or transport error.")

# A pipe or a log file gets 132 columns rather than rich's 80, so that tables are not truncated.
out = Console(highlight=False, soft_wrap=True, width=None if sys.stdout.isatty() else 132)
err = Console(stderr=True, highlight=False, soft_wrap=True, width=None if sys.stderr.isatty() else 132)

# ------------------------------------------------------------------------------------------------ options
Local = Annotated[bool, typer.Option("--local", help="compute in this process with the service's own code "
                                                     "(no server; needs the full install); answers are identical to a server's")]
Url = Annotated[str, typer.Option("--url", envvar="ZWIDTH_URL", help="service URL")]
Token = Annotated[str | None, typer.Option("--token", envvar="ZWIDTH_API_TOKEN", show_default=False,
                                           help="bearer token (ZWIDTH_API_TOKEN)")]
AsJson = Annotated[bool, typer.Option("--json", help="print the service's JSON answer (for scripts)")]
Preset = Annotated[str | None, typer.Argument(help="preset name (see `zwidth presets`)", show_default=False)]
Sets = Annotated[list[str] | None, typer.Option(
    "--set", "-s", metavar="PATH=VALUE",
    help="override a dotted field, e.g. device.delay=3e-3, device.cable.stiffness=5e4, "
         "requirements.min_gain_margin_db=10; VALUE is JSON (null removes a block) or text")]
DeviceFile = Annotated[Path | None, typer.Option("--device-file", exists=True, dir_okay=False,
                                                 help="device object as JSON or YAML")]
SceneFile = Annotated[Path | None, typer.Option("--scene-file", exists=True, dir_okay=False,
                                                help="scene object as JSON or YAML")]


class Connection:
    """Where the answers come from: ``--local`` or ``--url``/``--token``."""

    def __init__(self, local: bool, url: str = DEFAULT_URL, token: str | None = None):
        self.local, self.url, self.token = local, url, token


@contextlib.contextmanager
def client_with_status(conn: Connection, message: str, quiet: bool) -> Iterator[ZwidthClient]:
    """The client, with a spinner on stderr while the call runs."""
    with open_client(conn) as zw, progress_status(message, quiet):
        yield zw


@contextlib.contextmanager
def open_client(conn: Connection) -> Iterator[ZwidthClient]:
    if conn.local:
        from .local import LocalTransport

        with full_install("--local"):
            transport = LocalTransport()
        with ZwidthClient("http://zwidth.local", transport=transport) as client:
            yield client
    else:
        with ZwidthClient(conn.url, token=conn.token) as client:
            yield client


@contextlib.contextmanager
def full_install(what: str) -> Iterator[None]:
    """``--local`` and ``serve`` run the server's code: in a client-only install that is a usage error (exit 2)."""
    try:
        yield
    except ModuleNotFoundError as exc:
        if (exc.name or "").split(".")[0] in ("clients", "typer", "httpx", "pydantic", "rich"):
            raise
        raise usage_error(f"{what} runs the service's code in this process, which needs the full install of zwidth "
                          f"(server and numerics: `pip install zwidth`); this one has the client only "
                          f"(no module named {exc.name!r}). Without it, use --url of a running service.") from None


# ------------------------------------------------------------------------------------------------ errors
def exit_unless_optimal(status: str) -> None:
    """A design that is not ``optimal`` (infeasible, failed, or unsafe by its own exact check: no safe design
    delivered) ends with exit code 1."""
    if status != "optimal":
        raise typer.Exit(EXIT_NO)


Verify = Annotated[bool, typer.Option("--verify", help="add an independent closed-loop check of the answer "
                                                      "(docs/verification.md); exit 1 if it is contradicted")]


def verification_rows(v: Any) -> list[tuple[str, Any, str]]:
    """Table rows of a ``verification`` record (none when it was not asked for)."""
    if v is None:
        return []
    if getattr(v, "points", None):   # a robust design: one verdict per checked device of the box
        rows = [("verification", v.verdict, ""), ("verified by", v.method, "")]
        rows += [(f"verified {p.kind}", f"{', '.join(f'{k} = {x:.6g}' for k, x in p.device.items())}: {p.verdict}, "
                  f"margin {fmt(p.gain_margin_db)} dB" + (f" ({p.reason})" if p.reason else ""), "")
                 for p in v.points]
        return rows + [("verification time", v.elapsed_ms, "ms"), ("verification note", v.reason, "")]
    rows = [("verification", v.verdict, ""), ("verified by", v.method, ""), ("verification ε", v.epsilon, ""),
            ("radius below / above", f"{fmt(v.radius_below, 12)} / {fmt(v.radius_above, 12)}"
             if v.radius_below is not None or v.radius_above is not None else
             f"{fmt(v.unstable_poles_below)} / {fmt(v.unstable_poles_above)} unstable poles", ""),
            ("verification time", v.elapsed_ms, "ms")]
    if v.passivity is not None:
        rows.append(("passivity verified", v.passivity.verdict, ""))
    if v.reason:
        rows.append(("verification note", v.reason, ""))
    return rows


def exit_if_contradicted(v: Any) -> None:
    """A contradicted answer never exits 0."""
    if v is not None and v.verdict == "contradicted":
        raise typer.Exit(EXIT_NO)


def usage_error(message: str) -> typer.Exit:
    err.print(f"[bold red]error:[/] {escape(message)}")
    return typer.Exit(EXIT_USAGE)


F = TypeVar("F", bound=Callable[..., Any])


def handle_errors(fn: F) -> F:
    """Turn the client's exceptions into a message on stderr and the documented exit code."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return fn(*args, **kwargs)
        except ValidationFailed as exc:
            err.print("[bold red]invalid request[/] (422):")
            for e in exc.errors or [{"loc": ["body"], "msg": str(exc.detail)}]:
                name = ".".join(str(p) for p in e.get("loc", ())[1:]) or "body"
                err.print(escape(f"  {name}: {e.get('msg')}"))
            raise typer.Exit(EXIT_USAGE) from None
        except TransportError as exc:
            err.print(f"[bold red]no answer from the service:[/] {escape(str(exc))}")
            raise typer.Exit(EXIT_SERVICE) from None
        except (APIError, ProtocolError, ZwidthError) as exc:
            err.print(f"[bold red]service error:[/] {escape(str(exc))}")
            raise typer.Exit(EXIT_SERVICE) from None

    return wrapper  # type: ignore[return-value]


# ------------------------------------------------------------------------------------------------ requests
def _value(text: str) -> Any:
    try:
        return json.loads(text)
    except ValueError:
        return text


def _load_file(path: Path) -> dict[str, Any]:
    text = path.read_text(encoding="utf-8")
    try:
        if path.suffix.lower() in (".yaml", ".yml"):
            import yaml

            data = yaml.safe_load(text)
        else:
            data = json.loads(text)
    except Exception as exc:  # noqa: BLE001 - any parse error is the user's file, reported as usage
        raise usage_error(f"{path}: cannot parse ({exc})") from None
    if not isinstance(data, dict):
        raise usage_error(f"{path}: expected an object at the top level")
    return data


def _put(target: dict[str, Any], path: Sequence[str], value: Any, where: str) -> None:
    node = target
    for key in path[:-1]:
        child = node.get(key)
        if child is None:
            child = node[key] = {}
        if not isinstance(child, dict):
            raise usage_error(f"--set {where}: {key} is not an object")
        node = child
    node[path[-1]] = value


def assemble(roots: Mapping[str, dict[str, Any] | None], sets: Sequence[str] | None,
             files: Mapping[str, Path | None] | None = None) -> dict[str, Any]:
    """A request body: each root from its file (if any), then the ``--set PATH=VALUE`` overrides.

    ``roots`` maps the request's top-level names that this command accepts
    (``device``, ``requirements`` …) to their starting objects; ``None`` leaves a
    root out unless it is set.  A path must start with one of these names.
    """
    body: dict[str, Any] = {k: dict(v) for k, v in roots.items() if v is not None}
    for root, path in (files or {}).items():
        if path is not None:
            body[root] = {**body.get(root, {}), **_load_file(path)}
    for item in sets or []:
        name, eq, raw = item.partition("=")
        parts = name.strip().split(".")
        if not eq or not name.strip() or any(not p for p in parts):
            raise usage_error(f"--set {item!r}: expected PATH=VALUE, e.g. device.delay=3e-3")
        if parts[0] not in roots:
            raise usage_error(f"--set {item!r}: the path must start with one of "
                              f"{', '.join(r + '.' for r in roots)} (e.g. device.{name})")
        if len(parts) == 1:
            raise usage_error(f"--set {item!r}: name a field inside {parts[0]}, e.g. {parts[0]}.<field>")
        body.setdefault(parts[0], {})
        _put(body, parts, _value(raw), item)
    return body


def device_root(preset: str | None, device_file: Path | None, sets: Sequence[str] | None) -> dict[str, Any]:
    """The starting device object: ``{"preset": name}`` or the file (the --set overrides come later)."""
    device: dict[str, Any] = {}
    if device_file is not None:
        device = _load_file(device_file)
    if preset is not None:
        device["preset"] = preset
    if not device and not any(s.strip().startswith("device.") for s in sets or []):
        raise usage_error("name a device: a preset (see `zwidth presets`), --device-file, or --set device.mass=… "
                          "--set device.damping=…")
    return device


def scene_root(experiment: str | None, duration: float | None, stiffness: float | None,
               damping: float | None, position: float | None, velocity: float | None, relay_amplitude: float | None,
               effects: list[str] | None) -> dict:
    scene: dict = {}
    if experiment is not None:
        scene["experiment"] = experiment
    if duration is not None:
        scene["duration"] = duration
    if stiffness is not None or damping is not None:
        scene["controller"] = {"stiffness": stiffness if stiffness is not None else 0.0,
                               **({"damping": damping} if damping is not None else {})}
    if position is not None or velocity is not None:
        scene["initial"] = {k: v for k, v in (("position", position), ("velocity", velocity)) if v is not None}
    if relay_amplitude is not None:
        scene["relay"] = {"amplitude": relay_amplitude}
    if effects:
        scene["effects"] = {name: {} for name in effects}
    return scene



# ------------------------------------------------------------------------------------------------ output
def fmt(value: Any, digits: int = 6) -> str:
    if value is None:
        return "—"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return f"{value:.{digits}g}"
    return str(value)


#: Presets whose numbers are about a joint (the service's models.device.ROTARY_PRESETS; a test holds them equal):
#: their answers read in N·m/rad, N·m·s/rad and kg·m² where a linear device's read in N/m, N·s/m and kg.
ROTARY_PRESETS = frozenset({"phantom-1.0"})
_ROTARY_UNITS = {"N/m": "N·m/rad", "N·s/m": "N·m·s/rad", "kg": "kg·m²"}


def is_rotary(device: Any) -> bool:
    """The device dict sent (preset name, a device file's content) names a rotary preset."""
    return isinstance(device, Mapping) and device.get("preset") in ROTARY_PRESETS


def unit_of(unit: str, device: Any) -> str:
    """``unit`` as the device reads it: N/m for a linear device, N·m/rad for a rotary one."""
    return _ROTARY_UNITS.get(unit, unit) if is_rotary(device) else unit


def table(title: str, rows: Sequence[tuple[str, Any] | tuple[str, Any, str]], unit_col: bool = True,
          device: Any = None) -> Table:
    """A two- or three-column table of (name, value[, unit]) rows; ``device`` (the device dict of the request)
    makes the units rotary for a rotary preset."""
    t = Table(title=title, show_header=False, title_justify="left")
    t.add_column("quantity", style="bold")
    t.add_column("value", justify="right")
    if unit_col:
        t.add_column("unit", style="dim")
    for row in rows:
        name, value, *unit = row
        # numbers line up on the right, sentences read from the left
        cell = Text(fmt(value), justify="left" if isinstance(value, str) else "right")
        t.add_row(Text(name), cell, *([Text(unit_of(str(u), device)) for u in unit[:1]] if unit_col else []))
    return t


def emit(result: BaseModel | Sequence[BaseModel] | Mapping[str, Any], as_json: bool,
         human: Callable[[], None]) -> None:
    """``--json``: the answer as the service sent it; else the human view."""
    if as_json:
        def dump(x: Any) -> Any:
            if isinstance(x, BaseModel):
                return x.model_dump(mode="json")
            if isinstance(x, Mapping):
                return {k: dump(v) for k, v in x.items()}
            if isinstance(x, (list, tuple)):
                return [dump(v) for v in x]
            return x
        sys.stdout.write(json.dumps(dump(result), indent=2, allow_nan=False) + "\n")
    else:
        human()


def emit_design(result: Any, as_json: bool, title: str, device: Any,
                rows: Callable[[], list[tuple[str, Any, str]]]) -> None:
    """A design's answer (``--json`` or a table of ``rows()`` and its verification), then its exit code:
    1 when the verification contradicts it or it is not ``optimal``."""
    emit(result, as_json, lambda: out.print(table(title, rows() + verification_rows(result.verification),
                                                  device=device)))
    exit_if_contradicted(result.verification)
    exit_unless_optimal(result.status)


@contextlib.contextmanager
def progress_status(message: str, quiet: bool) -> Iterator[None]:
    """A spinner on stderr while the service works (never on stdout, which scripts read)."""
    if quiet:
        yield
        return
    with err.status(message):
        yield
