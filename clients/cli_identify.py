"""``zwidth identify data.csv``: a device and its uncertainty from a lab's measurements (POST /v1/identify).

The CSV has a header row naming its columns: ``time,force,position`` (a time series at the loop's rate: s, N,
m) or ``frequency,real,imag`` (a measured X/F: rad/s, m/N).  Other columns are ignored.
"""

from __future__ import annotations

import csv
import itertools
import math
from pathlib import Path
from typing import Annotated, Any

import typer

from . import cli_common as c
from .cli_common import DEFAULT_URL, AsJson, Connection, Local, Token, Url, emit, handle_errors, out

__all__ = ["identify", "read_csv"]


def read_csv(path: Path) -> dict[str, Any]:
    """The ``data`` object of POST /v1/identify from a CSV file (raises typer.Exit with a usage error)."""
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            rows = list(csv.reader(fh))
    except OSError as exc:
        raise c.usage_error(f"{path}: {exc.strerror or exc}") from None
    if not rows:
        raise c.usage_error(f"{path}: empty file")
    header = [h.strip().lower() for h in rows[0]]
    for kind, cols in (("time_series", ("time", "force", "position")),
                       ("frequency_response", ("frequency", "real", "imag"))):
        if all(col in header for col in cols):
            break
    else:
        raise c.usage_error(f"{path}: the header must name the columns time,force,position or frequency,real,imag "
                            f"(got {','.join(header)})")
    idx = [header.index(col) for col in cols]
    values: dict[str, list[float]] = {col: [] for col in cols}
    for line, row in enumerate(rows[1:], start=2):
        if not row or all(not cell.strip() for cell in row):
            continue
        try:
            for col, i in zip(cols, idx):
                values[col].append(float(row[i]))
        except (ValueError, IndexError):
            raise c.usage_error(f"{path}:{line}: expected numbers in columns {','.join(cols)}") from None
    if kind == "frequency_response":
        return {"kind": kind, **values}
    t = values.pop("time")
    if len(t) < 2:
        raise c.usage_error(f"{path}: a time series needs at least 2 rows")
    steps = [b - a for a, b in itertools.pairwise(t)]
    dt = sum(steps) / len(steps)
    if not (dt > 0 and all(math.isclose(s, dt, rel_tol=1e-3, abs_tol=1e-12) for s in steps)):
        raise c.usage_error(f"{path}: the time column must be uniformly sampled (one row per sample period)")
    return {"kind": kind, "sample_time": float(f"{dt:.12g}"), **values}


def _known(items: list[str] | None) -> dict[str, float] | None:
    if not items:
        return None
    out_: dict[str, float] = {}
    for item in items:
        name, sep, value = item.partition("=")
        try:
            out_[name.strip()] = float(value)
        except ValueError:
            raise c.usage_error(f"--known {item!r}: expected name=value, e.g. delay=0.0005") from None
        if not sep:
            raise c.usage_error(f"--known {item!r}: expected name=value, e.g. delay=0.0005")
    return out_


@handle_errors
def identify(csv_file: Annotated[Path, typer.Argument(help="CSV: time,force,position or frequency,real,imag")],
             model: Annotated[str, typer.Option(help="rigid | cable | auto")] = "auto",
             friction: Annotated[bool, typer.Option("--friction", help="fit Coulomb friction (time series)")] = False,
             known: Annotated[list[str] | None, typer.Option("--known", help="hold a parameter fixed: name=value")] = None,
             confidence: Annotated[float | None, typer.Option(help="confidence level of the intervals")] = None,
             sample_time: Annotated[float | None, typer.Option(help="the device's T [s] (frequency response)")] = None,
             max_delay: Annotated[float | None, typer.Option(help="largest delay searched [s]")] = None,
             response: Annotated[str | None, typer.Option(help="continuous | sampled (frequency response)")] = None,
             plot: Annotated[Path | None, typer.Option(help="also save the measured-vs-fitted plot (.png/.svg)")] = None,
             local: Local = False, url: Url = DEFAULT_URL, token: Token = None, as_json: AsJson = False) -> None:
    """Identify the device from measurements (POST /v1/identify): parameters with intervals, the device and
    the uncertainty box for `zwidth robust`/requirements.uncertainty.

    Exit 1 when the fit failed.
    """
    data = read_csv(csv_file)
    if response is not None:
        if data["kind"] != "frequency_response":
            raise c.usage_error("--response applies to a frequency response (columns frequency,real,imag)")
        data["response"] = response
    kw = dict(model=model, known=_known(known), friction=friction or None, confidence=confidence,
              sample_time=sample_time, max_delay=max_delay)
    with c.client_with_status(Connection(local, url, token), "identifying…", as_json) as zw:
        r = zw.identify(data, **kw)
        if plot is not None and r.status != "failed":
            fmt = "svg" if plot.suffix.lower() == ".svg" else "png"
            zw.plot_identify(data, format=fmt, **kw).save(str(plot))

    def human() -> None:
        rows: list[tuple] = [("status", r.status, ""), ("model", r.model, ""), ("why", r.reason, "")]
        for name, p in r.parameters.items():
            lo, hi = p.interval
            rows.append((name, p.value, f"± {c.fmt(p.std_error, 3)}  [{c.fmt(lo)}, {c.fmt(hi)}]"))
        if r.fit is not None:
            w = r.fit.residual_whiteness
            rows += [("NRMSE", r.fit.nrmse, ""),
                     ("residual white", w.get("white"), f"Ljung–Box p = {c.fmt(w.get('p_value'), 3)}")]
        rows += [("compared", f"{x.model}: BIC {c.fmt(x.bic, 8)}, NRMSE {c.fmt(x.nrmse, 3)}", x.status)
                 for x in r.comparison]
        rows += [("warning", w_, "") for w_ in r.warnings]
        rows.append(("elapsed", r.elapsed_ms, "ms"))
        out.print(c.table(f"identification ({r.confidence:g} intervals)", rows))
    emit(r, as_json, human)
    if r.status != "identified":
        raise typer.Exit(c.EXIT_NO)
