"""``zwidth study run|status|results|cancel``: batch studies on a zwidth server, with a progress bar.

Every call goes through :class:`clients.ZwidthClient` (its timeouts, retries and errors), and the
exit codes are every ``zwidth`` command's (clients/cli_common.py): 0 ok, 1 the study did not finish
``done``, 2 a 422 (the message names the field) or bad usage, 3 the service could not answer.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import typer

from .cli_common import EXIT_NO, Token, Url, err, handle_errors, out, usage_error
from .client import DEFAULT_URL, ZwidthClient
from .errors import APIError

app = typer.Typer(help="Batch design-space studies on a zwidth server (POST /v1/studies).", no_args_is_help=True)

_ACTIVE = ("queued", "running", "cancelling")


def _client(url: str, token: str | None) -> ZwidthClient:
    """The client of every study command (tests replace it with one on an in-process app)."""
    return ZwidthClient(url, token=token)


def _duration(seconds: float) -> str:
    s = int(round(seconds))
    return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}" if s >= 3600 else f"{s // 60}:{s % 60:02d}"


def progress_fields(st) -> dict[str, str]:
    """The bar's rate and ETA as the service measures them (points per second of this run, seconds left)."""
    return {"rate": f"{st.rate:.3g} pts/s" if st.rate else "— pts/s",
            "eta": f"ETA {_duration(st.eta_s)}" if st.eta_s is not None else "ETA —"}


def _follow(zw: ZwidthClient, study_id: str, poll: float):
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn

    with Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                  TextColumn("points, {task.fields[rate]}, {task.fields[eta]}"), console=err,
                  transient=False) as bar:
        st = zw.study(study_id)
        task = bar.add_task(study_id[:8], total=st.total, **progress_fields(st))
        while True:
            bar.update(task, completed=st.done, description=f"{study_id[:8]} {st.status}", **progress_fields(st))
            if st.status not in _ACTIVE:
                return st
            time.sleep(poll)
            st = zw.study(study_id)


def _read_request(request: Path) -> dict:
    try:
        body = json.loads(sys.stdin.read() if str(request) == "-" else request.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise usage_error(f"{request}: cannot read a JSON study request ({exc})") from None
    if not isinstance(body, dict):
        raise usage_error(f"{request}: expected a JSON object (problem, base, sweep)")
    return body


@app.command()
@handle_errors
def run(request: Path = typer.Argument(..., help="study request (JSON file), '-' for stdin"),
        url: Url = DEFAULT_URL, token: Token = None,
        wait: bool = typer.Option(True, help="follow the study with a progress bar"),
        poll: float = typer.Option(0.5, min=0.05, help="seconds between status polls")) -> None:
    """Submit a study; print its id (and follow it to the end with --wait)."""
    body = _read_request(request)
    with _client(url, token) as zw:
        created = zw.submit_study(body)
        out.print(f"study {created.id}: {created.points} points ({created.problem})")
        if wait:
            st = _follow(zw, created.id, poll)
            out.print(f"{st.status}: {st.done}/{st.total} points, {st.failed} failed"
                      + (f" ({st.error})" if st.error else ""))
            if st.status != "done":
                raise typer.Exit(EXIT_NO)


@app.command()
@handle_errors
def status(study_id: str = typer.Argument(None, help="study id; all studies when omitted"),
           url: Url = DEFAULT_URL, token: Token = None, as_json: bool = typer.Option(False, "--json")) -> None:
    """Status, progress, rate and ETA of a study (or a list of all)."""
    with _client(url, token) as zw:
        data = zw.study(study_id) if study_id else zw.studies()
    if as_json:
        sys.stdout.write(data.model_dump_json(indent=2) + "\n")
        return
    for st in ([data] if study_id else data.studies):
        eta = f", ETA {_duration(st.eta_s)}" if st.eta_s else ""
        rate = f", {st.rate:.3g} pts/s" if st.rate else ""
        out.print(f"{st.id}  {st.problem:9} {st.status:9} {st.done}/{st.total} ({st.failed} failed){rate}{eta}")


@app.command()
@handle_errors
def results(study_id: str, url: Url = DEFAULT_URL, token: Token = None,
            fmt: str = typer.Option("csv", "--format", help="csv | parquet | json"),
            dest: Path = typer.Option(None, "--out", help="file to write; stdout for csv/json when omitted")) -> None:
    """Download a study's results (JSON gathers every page)."""
    if fmt not in ("csv", "parquet", "json"):
        raise usage_error("--format must be csv, parquet or json")
    if fmt == "parquet" and dest is None:
        raise usage_error("--out is required for parquet")
    with _client(url, token) as zw:
        if fmt == "json":
            rows: list = []
            offset: int | None = 0
            while offset is not None:
                page = zw.study_results(study_id, offset=offset, limit=10000)
                rows += page.rows
                offset = page.next_offset
            payload = json.dumps(rows, indent=1).encode()
        else:
            payload = zw.export_study(study_id, fmt).content
    if dest is None:
        sys.stdout.write(payload.decode())
    else:
        dest.write_bytes(payload)
        out.print(f"wrote {dest} ({len(payload)} bytes)")


@app.command()
@handle_errors
def cancel(study_id: str, url: Url = DEFAULT_URL, token: Token = None,
           purge: bool = typer.Option(False, help="also delete the study and its stored rows")) -> None:
    """Cancel a queued or running study (stored results stay unless --purge)."""
    with _client(url, token) as zw:
        st = zw.cancel_study(study_id)
        if purge:
            # the service answers 409 while the runner is still stopping the study: ask again for a while
            deadline = time.monotonic() + 30.0
            while True:
                try:
                    st = zw.cancel_study(study_id, purge=True)
                    break
                except APIError as exc:
                    if exc.status != 409 or time.monotonic() > deadline:
                        raise
                    time.sleep(0.2)
    out.print(f"{study_id}: purged" if st is None else f"{st.id}: {st.status} at {st.done}/{st.total}")
