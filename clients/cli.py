"""The ``zwidth`` command line."""

from __future__ import annotations

import json
import math

import typer

app = typer.Typer(help="zwidth: the stiffest wall, the lightest feel and the filter that are still safe to render.",
                  no_args_is_help=True)


@app.command()
def analyze(preset: str = typer.Argument("lhifam", help="preset name, or 'all'"),
            local: bool = typer.Option(True, help="compute in-process (no server)"),
            as_json: bool = typer.Option(False, "--json", help="machine-readable output")) -> None:
    """Exact critical stiffness of a preset (rigid and cable models) beside the linear estimate (eq. 10)."""
    from models.device import PRESETS, Device
    from optim.margins import critical_stiffness, linear_estimate

    names = sorted(PRESETS) if preset == "all" else [preset]
    rows = []
    for name in names:
        if name not in PRESETS:
            typer.echo(f"unknown preset {name!r}; known: {', '.join(sorted(PRESETS))}", err=True)
            raise typer.Exit(2)
        full = Device(preset=name)
        for label, dev in (("cable", full), ("rigid", full.rigid())):
            if label == "cable" and dev.cable is None:
                continue
            r = critical_stiffness(dev)
            rows.append({"preset": name, "model": label, "critical_stiffness": r.critical_stiffness,
                         "gain_db": 20 * math.log10(r.critical_stiffness),
                         "crossover_frequency": r.crossover_frequency,
                         "linear_estimate": linear_estimate(dev)})
    if as_json:
        typer.echo(json.dumps(rows, indent=2))
        return
    typer.echo(f"{'preset':28} {'model':6} {'K_cr exact':>14} {'dB':>8} {'w_cr rad/s':>11} {'K linear eq.10':>15}")
    for r in rows:
        typer.echo(f"{r['preset']:28} {r['model']:6} {r['critical_stiffness']:14.6g} {r['gain_db']:8.3f} "
                   f"{r['crossover_frequency']:11.5g} {r['linear_estimate']:15.6g}")


bench_app = typer.Typer(help="Benchmarks that write their tables into docs/.", no_args_is_help=True)
app.add_typer(bench_app, name="bench")


@bench_app.command("accuracy")
def bench_accuracy(quick: bool = typer.Option(False, help="the 5-case version"),
                   repeats: int = typer.Option(7, min=1),
                   out: str = typer.Option("docs/accuracy.md")) -> None:
    """What accuracy costs in time: the ladder and python-control on one suite (docs/accuracy.md, .png)."""
    from bench import accuracy_vs_time

    accuracy_vs_time.main((["--quick"] if quick else []) + ["--repeats", str(repeats), "--out", out])


@bench_app.command("core")
def bench_core(repeats: int = typer.Option(30, min=1), out: str = typer.Option("docs/bench_core.md")) -> None:
    """Exact K_cr against python-control's stability_margins (docs/bench_core.md)."""
    from bench import bench_core as core

    core.main(["--repeats", str(repeats), "--out", out])


@app.command()
def serve(host: str = typer.Option("127.0.0.1", help="interface to bind (0.0.0.0 in a container)"),
          port: int = typer.Option(8000, min=1, max=65535, help="TCP port"),
          workers: int = typer.Option(1, min=1, help="uvicorn worker processes (each with its own compute pool)"),
          log_level: str = typer.Option("info", help="log level (logs are JSON lines on stderr)")) -> None:
    """Serve the HTTP API with uvicorn (settings from ZWIDTH_* environment variables)."""
    import uvicorn

    from service.logs import uvicorn_log_config

    uvicorn.run("service.app:app", host=host, port=port, workers=workers, log_level=log_level,
                log_config=uvicorn_log_config(log_level), access_log=False, proxy_headers=False)


if __name__ == "__main__":  # pragma: no cover
    app()
