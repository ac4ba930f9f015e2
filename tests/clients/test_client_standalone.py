"""The client stands alone: it imports, prints its help and reads real answers without the server or the numerics.

Each check runs in a fresh interpreter.  The strongest one refuses every import of the server and the numerics
(as a client-only install would: no ``service``, ``optim``, ``models``, numpy, scipy …) and then drives the
CLI's help and the Python client over a mock transport with an answer the real app gave.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import pytest

pytestmark = pytest.mark.slow

SERVER = ("service", "optim", "models")
NUMERICS = ("numpy", "scipy", "mpmath", "casadi", "matplotlib", "fastapi", "starlette", "uvicorn", "sqlalchemy",
            "dask", "pyarrow")
HELP = [["--help"], ["analyze", "--help"], ["feedforward", "--help"], ["design", "stiffness", "--help"],
        ["robust", "hardware", "--help"], ["plot", "bode", "--help"], ["study", "run", "--help"],
        ["identify", "--help"], ["simulate", "--help"], ["presets", "--help"], ["serve", "--help"],
        ["bench", "--help"]]


def _run(code: str) -> dict:
    done = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


LOADED = f"sorted(m for m in sys.modules if m.split('.')[0] in {SERVER + NUMERICS!r})"


@pytest.mark.parametrize("statement", ["import clients", "import clients.cli", "from clients.cli import app",
                                       "from clients import ZwidthClient, AsyncZwidthClient, calls, schemas"])
def test_importing_the_client_loads_no_server_or_numerics_module(statement):
    loaded = _run(f"import json, sys\n{statement}\nprint(json.dumps({LOADED}))")
    assert loaded == [], f"{statement!r} imported {loaded}"


def test_cli_help_imports_nothing_from_the_server():
    """`zwidth --help` and the subcommands' --help, through the real entry point, in one interpreter."""
    loaded = _run(f"""
        import json, sys
        from typer.testing import CliRunner
        from clients.cli import app
        codes = [CliRunner().invoke(app, args).exit_code for args in {HELP!r}]
        assert codes == [0] * len(codes), codes
        print(json.dumps({LOADED}))
        """)
    assert loaded == []


@pytest.fixture(scope="module")
def stability_answer() -> str:
    """One real answer of the current app (in-process, the full install of this checkout)."""
    from clients import ZwidthClient
    from clients.local import LocalTransport

    with ZwidthClient(transport=LocalTransport()) as zw:
        r = zw.stability({"preset": "lhifam", "cable": None, "delay": 0.001}, {"stiffness": 3000, "damping": 2},
                         verify=True)
    return r.model_dump_json()


def test_a_client_only_install_works_without_the_server(stability_answer):
    """With the server and the numerics impossible to import: help works, a real answer is read and typed,
    and --local / serve say that they need the full install (exit 2) instead of a traceback."""
    report = _run(f"""
        import importlib.abc, json, sys

        class ClientOnly(importlib.abc.MetaPathFinder):
            def find_spec(self, name, path, target=None):
                if name.split(".")[0] in {SERVER + NUMERICS!r}:
                    raise ModuleNotFoundError(f"No module named {{name!r}}", name=name)
                return None

        sys.meta_path.insert(0, ClientOnly())
        import httpx
        from typer.testing import CliRunner
        from clients import ZwidthClient, schemas
        from clients.cli import app

        runner = CliRunner()
        helps = [runner.invoke(app, args).exit_code for args in {HELP!r}]
        answer = {stability_answer!r}
        mock = httpx.MockTransport(lambda request: httpx.Response(200, content=answer.encode(),
                                                                  headers={{"content-type": "application/json"}}))
        with ZwidthClient("http://zwidth.test", transport=mock) as zw:
            r = zw.stability({{"preset": "lhifam"}}, {{"stiffness": 3000, "damping": 2}}, verify=True)
        local = runner.invoke(app, ["analyze", "lhifam", "--local"])
        serve = runner.invoke(app, ["serve"])
        print(json.dumps({{"helps": helps, "typed": isinstance(r, schemas.StabilityResponse),
                          "verdict": r.verification.verdict, "kcr": r.critical_stiffness,
                          "local": [local.exit_code, local.output], "serve": [serve.exit_code, serve.output]}}))
        """)
    assert report["helps"] == [0] * len(HELP)
    original = json.loads(stability_answer)
    assert report["typed"] and report["kcr"] == original["critical_stiffness"]
    assert report["verdict"] == original["verification"]["verdict"] == "confirmed"
    for what in ("local", "serve"):
        code, output = report[what]
        assert code == 2 and "full install" in output, (what, code, output)


def test_the_client_only_distribution_lists_every_client_package_and_no_numerics():
    """clients/pyproject.toml (`pip install ./clients`): every package of clients/ is in it, and its
    dependencies are the client's own (checked once by installing it into an empty venv: no numpy, no scipy)."""
    import tomllib
    from pathlib import Path

    root = Path(__file__).resolve().parents[2] / "clients"
    project = tomllib.loads((root / "pyproject.toml").read_text(encoding="utf-8"))
    packages = {"clients", *("clients." + ".".join(p.parent.relative_to(root).parts)
                             for p in root.rglob("__init__.py") if p.parent != root and "build" not in p.relative_to(root).parts)}
    assert set(project["tool"]["setuptools"]["packages"]) == packages
    deps = {d.split(">")[0].split("=")[0].split("[")[0].strip().lower() for d in project["project"]["dependencies"]}
    assert deps == {"httpx", "pydantic", "typer", "rich", "pyyaml"}
    assert project["project"]["scripts"] == {"zwidth": "clients.cli:app"}
