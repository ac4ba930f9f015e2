"""``zwidth study run|status|results|cancel``: batch studies on a zwidth server, with a progress bar.

Exit codes as every ``zwidth`` command (clients/cli_common.py): 0 ok, 1 the study did not finish
``done``, 2 a 422 (the message names the field) or bad usage, 3 the service could not answer.
"""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

import httpx
import typer

app = typer.Typer(help="Batch design-space studies on a zwidth server (POST /v1/studies).", no_args_is_help=True)

_SERVER = typer.Option("http://127.0.0.1:8000", "--url", "--server", envvar="ZWIDTH_URL", help="service URL")
_ACTIVE = ("queued", "running")


class _Service(httpx.Client):
    """httpx.Client whose transport failures end the command with exit code 3."""

    def send(self, *args, **kw):
        try:
            return super().send(*args, **kw)
        except httpx.TransportError as exc:
            typer.echo(f"error: the service at {self.base_url} did not answer ({type(exc).__name__}: {exc})", err=True)
            raise typer.Exit(3) from None


def _client(server: str) -> httpx.Client:
    token = os.environ.get("ZWIDTH_API_TOKEN")
    headers = {"Authorization": f"Bearer {token}"} if token else {}
    # Per kind of call: submissions and exports may take a while, status polls should not.
    return _Service(base_url=server, headers=headers, timeout=httpx.Timeout(10.0, read=300.0))


def _check(r: httpx.Response) -> dict:
    if r.status_code >= 400:
        code = 2 if r.status_code == 422 else 3
        try:
            detail = r.json().get("detail")
        except ValueError:
            detail = r.text
        if isinstance(detail, list):
            detail = "; ".join(f"{'.'.join(map(str, e.get('loc', ())))}: {e.get('msg')}" for e in detail)
        typer.echo(f"error {r.status_code}: {detail}", err=True)
        raise typer.Exit(code)
    return r.json() if r.headers.get("content-type", "").startswith("application/json") else {}


def _follow(http: httpx.Client, study_id: str, poll: float) -> dict:
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    with Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                  TextColumn("{task.fields[rate]}"), TimeRemainingColumn(), transient=False) as bar:
        st = _check(http.get(f"/v1/studies/{study_id}"))
        task = bar.add_task(study_id[:8], total=st["total"], rate="")
        while True:
            rate = f"{st['rate']:.0f} pts/s" if st.get("rate") else ""
            bar.update(task, completed=st["done"], rate=rate, description=f"{study_id[:8]} {st['status']}")
            if st["status"] not in _ACTIVE:
                return st
            time.sleep(poll)
            st = _check(http.get(f"/v1/studies/{study_id}"))


@app.command()
def run(request: Path = typer.Argument(..., help="study request (JSON file), '-' for stdin"),
        server: str = _SERVER, wait: bool = typer.Option(True, help="follow the study with a progress bar"),
        poll: float = typer.Option(0.5, min=0.05, help="seconds between status polls")) -> None:
    """Submit a study; print its id (and follow it to the end with --wait)."""
    body = json.loads(sys.stdin.read() if str(request) == "-" else request.read_text())
    with _client(server) as http:
        created = _check(http.post("/v1/studies", json=body))
        typer.echo(f"study {created['id']}: {created['points']} points ({created['problem']})")
        if wait:
            st = _follow(http, created["id"], poll)
            typer.echo(f"{st['status']}: {st['done']}/{st['total']} points, {st['failed']} failed"
                       + (f" ({st['error']})" if st.get("error") else ""))
            if st["status"] != "done":
                raise typer.Exit(1)


@app.command()
def status(study_id: str = typer.Argument(None, help="study id; all studies when omitted"), server: str = _SERVER,
           as_json: bool = typer.Option(False, "--json")) -> None:
    """Status, progress, rate and ETA of a study (or a list of all)."""
    with _client(server) as http:
        data = _check(http.get(f"/v1/studies/{study_id}" if study_id else "/v1/studies"))
    if as_json:
        typer.echo(json.dumps(data, indent=2))
        return
    for st in ([data] if study_id else data["studies"]):
        eta = f", ETA {st['eta_s']:.0f} s" if st.get("eta_s") else ""
        rate = f", {st['rate']:.0f} pts/s" if st.get("rate") else ""
        typer.echo(f"{st['id']}  {st['problem']:9} {st['status']:9} {st['done']}/{st['total']} "
                   f"({st['failed']} failed){rate}{eta}")


@app.command()
def results(study_id: str, server: str = _SERVER,
            fmt: str = typer.Option("csv", "--format", help="csv | parquet | json"),
            out: Path = typer.Option(None, "--out", help="file to write; stdout for csv/json when omitted")) -> None:
    """Download a study's results (JSON gathers every page)."""
    if fmt not in ("csv", "parquet", "json"):
        typer.echo("--format must be csv, parquet or json", err=True)
        raise typer.Exit(2)
    if fmt == "parquet" and out is None:
        typer.echo("--out is required for parquet", err=True)
        raise typer.Exit(2)
    with _client(server) as http:
        if fmt == "json":
            rows, offset = [], 0
            while offset is not None:
                page = _check(http.get(f"/v1/studies/{study_id}/results", params={"offset": offset, "limit": 10000}))
                rows += page["rows"]
                offset = page["next_offset"]
            payload = json.dumps(rows, indent=1).encode()
        else:
            r = http.get(f"/v1/studies/{study_id}/results", params={"format": fmt})
            _check(r)
            payload = r.content
    if out is None:
        sys.stdout.write(payload.decode())
    else:
        out.write_bytes(payload)
        typer.echo(f"wrote {out} ({len(payload)} bytes)")


@app.command()
def cancel(study_id: str, server: str = _SERVER) -> None:
    """Cancel a queued or running study (stored results stay)."""
    with _client(server) as http:
        st = _check(http.delete(f"/v1/studies/{study_id}"))
    typer.echo(f"{st['id']}: {st['status']} at {st['done']}/{st['total']}")
