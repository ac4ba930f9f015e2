"""Every ``zwidth`` command against the real server process (CliRunner, --url at it), and --local beside it.

Exit codes under test: 0 ok, 1 the answer is no, 2 usage/validation, 3 service/transport.
"""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from clients.cli import app

from .conftest import has_route, without_timings

pytestmark = pytest.mark.slow

runner = CliRunner()


@pytest.fixture(autouse=True)
def _env(server, monkeypatch):
    monkeypatch.setenv("ZWIDTH_URL", server.url)
    monkeypatch.delenv("ZWIDTH_API_TOKEN", raising=False)


def run(*args: str, code: int = 0):
    result = runner.invoke(app, list(args))
    assert result.exit_code == code, (result.exit_code, result.stdout, result.stderr, result.exception)
    return result


def run_json(*args: str, code: int = 0):
    return json.loads(run(*args, "--json", code=code).stdout)


def local_equals_remote(*args: str, code: int = 0) -> dict:
    """The same command --local and against the server: identical JSON, number for number (timings aside)."""
    remote = run_json(*args, code=code)
    local = run_json(*args, "--local", code=code)
    assert without_timings(local) == without_timings(remote)
    return remote


# ------------------------------------------------------------------------------------------------ presets
def test_presets():
    data = run_json("presets")
    assert data["lhifam"]["cable"]["stiffness"] == 79500.0 and data["phantom-1.0"]["human"] is None
    assert "lhifam-reduced-pretension" in run("presets").stdout


# ------------------------------------------------------------------------------------------------ analyze
def test_analyze_local_and_remote_are_identical():
    r = local_equals_remote("analyze", "lhifam", "--set", "device.delay=1e-3", "--stiffness", "3500", "--damping", "5")
    assert r["stable"] is True and r["damping"] == 5.0


def test_analyze_table_and_the_rigid_preset_values():
    """Chapter Table 3: rigid LHifAM K_cr = 7000.756 N/m (76.90 dB), cable 8848.7 N/m (78.94 dB)."""
    r = run_json("analyze", "lhifam")
    assert r["critical_stiffness"] == pytest.approx(8848.7, rel=1e-5)
    assert r["rigid_critical_stiffness"] == pytest.approx(7000.756, rel=1e-6)
    text = run("analyze", "lhifam").stdout
    assert "critical stiffness K_cr" in text and "8848.71" in text


def test_analyze_all_presets():
    data = run_json("analyze", "all")
    assert set(data) == {"lhifam", "lhifam-reduced-pretension", "phantom-1.0"}
    assert "stability of every preset" in run("analyze", "all").stdout


def test_rotary_preset_tables_read_in_rotary_units():
    """phantom-1.0 is about a joint: its tables say N·m/rad and N·m·s/rad, a linear device's N/m and N·s/m."""
    from clients.cli_common import ROTARY_PRESETS
    from models.device import ROTARY_PRESETS as SERVICE_ROTARY

    assert ROTARY_PRESETS == SERVICE_ROTARY   # the client's copy of the service's list
    text = run("analyze", "phantom-1.0").stdout
    assert "N·m/rad" in text and "N·m·s/rad" in text and "N/m " not in text.replace("N·m/rad", "")
    linear = run("analyze", "lhifam").stdout
    assert "N·m/rad" not in linear and "N/m" in linear
    assert "phantom-1.0 rotary: N·m/rad" in run("analyze", "all").stdout


def test_analyze_an_unstable_wall_exits_1():
    r = run_json("analyze", "lhifam", "--set", "device.cable=null", "--stiffness", "8000", code=1)
    assert r["stable"] is False and r["gain_margin_db"] < 0


def test_device_file_json_and_yaml(tmp_path):
    (tmp_path / "dev.json").write_text(json.dumps({"mass": 5.4, "damping": 3.5, "delay": 0.001}))
    (tmp_path / "dev.yaml").write_text("mass: 5.4\ndamping: 3.5\ndelay: 0.0005\n")
    a = run_json("analyze", "--device-file", str(tmp_path / "dev.json"))
    b = run_json("analyze", "--device-file", str(tmp_path / "dev.yaml"), "--set", "device.delay=0.001")
    assert without_timings(a) == without_timings(b)


@pytest.mark.slow
def test_usage_errors_exit_2():
    r = run("analyze", "lhifam", "--set", "delay=1e-3", code=2)
    assert "device." in r.stderr
    run("analyze", "lhifam", "--set", "device.delay", code=2)
    run("analyze", code=2)                                         # no device at all
    run("analyze", "lhifam", "--damping", "5", code=2)             # B without K
    run("analyze", "lhifam", "--nonsense", code=2)                 # typer's own usage error


def test_analyze_a_filtered_wall_with_a_virtual_mass():
    r = local_equals_remote("analyze", "lhifam", "--set", "device.cable=null", "--stiffness", "3000", "--damping", "5",
                            "--velocity-filter", "low_pass:50:1", "--virtual-mass", "-1", "--verify")
    assert r["critical_stiffness"] > 3000 and r["verification"]["verdict"] == "confirmed"
    assert r["mass_range"]["min"] < -1 < r["mass_range"]["max"]
    k_only = run_json("analyze", "lhifam", "--set", "device.cable=null", "--velocity-filter", "moving_average:4")
    assert k_only["critical_stiffness"] > 0 and k_only.get("mass_range") is None
    run("analyze", "lhifam", "--velocity-filter", "low_pass", code=2)              # no cutoff
    r = run("analyze", "lhifam", "--velocity-filter", "low_pass:600", code=2)       # above Nyquist: the server's 422
    assert "controller.velocity_filter.cutoff_hz" in r.stderr


def test_boundary_of_a_filtered_wall_with_a_virtual_mass():
    args = ("boundary", "lhifam", "--set", "device.cable=null", "--points", "6")
    plain = local_equals_remote(*args)
    r = local_equals_remote(*args, "--velocity-filter", "low_pass:50:1", "--virtual-mass", "1")
    # the filter's lag lowers the boundary's optimum; the same answer as the analysis at the optimum's B
    assert 0 < r["optimum"]["critical_stiffness"] < plain["optimum"]["critical_stiffness"]
    one = run_json("analyze", "lhifam", "--set", "device.cable=null", "--damping", str(r["optimum"]["damping"]),
                   "--velocity-filter", "low_pass:50:1", "--virtual-mass", "1")
    assert one["critical_stiffness"] == pytest.approx(r["optimum"]["critical_stiffness"], rel=1e-12)
    text = run(*args, "--velocity-filter", "backward_difference").stdout
    assert "best K_cr" in text and "K_cr(B)" in text
    run(*args, "--velocity-filter", "moving_average:x", code=2)


def test_a_422_exits_2_naming_the_field():
    r = run("analyze", "lhifam", "--set", "device.delay=-1", code=2)
    assert "device.delay" in r.stderr and "greater than or equal to 0" in r.stderr
    r = run("analyze", "no-such-preset", code=2)
    assert "preset" in r.stderr


@pytest.mark.slow
def test_no_server_exits_3(dead_url):
    r = run("analyze", "lhifam", "--url", dead_url, code=3)
    assert "no answer from the service" in r.stderr and "3 attempts" in r.stderr


# ------------------------------------------------------------------------------------------------ design
@pytest.mark.slow
def test_design_stiffness_local_and_remote_are_identical():
    r = local_equals_remote("design", "stiffness", "lhifam", "--set", "device.delay=1e-3", "--margin", "6")
    assert r["status"] == "optimal" and 6.0 < r["gain_margin_db"] < 6.0 + 1e-7   # the design back-off (DESIGN_BACK_OFF)
    assert "stiffness design" in run("design", "stiffness", "lhifam", "--set", "device.delay=1e-3").stdout


def test_design_stiffness_requirements_by_set_and_infeasible_exits_1():
    r = run_json("design", "stiffness", "--set", "device.mass=2", "--set", "device.damping=0",
                 "--set", "requirements.passivity=true", code=1)
    assert r["status"] == "infeasible" and r["reason"]


def test_design_stiffness_over_a_workspace():
    """--workspace: requirements.workspace from the flags (a preset, Latin-hypercube poses, each pose's worst normal);
    the table shows the exchange and the denser set's margin; an unknown preset is a 422 naming the field."""
    base = ("design", "stiffness", "--set", "device.mass=1", "--set", "device.damping=0", "--set", "device.delay=1e-3",
            "--margin", "1", "--workspace", "planar-2link", "--workspace-poses", "3", "--verify-factor", "1")
    r = run_json(*base)
    assert r["status"] == "optimal" and r["workspace"]["design_poses"] == 3 and r["workspace"]["verification_poses"] > 3
    assert r["workspace"]["verification_margin"] >= 0 and r["stiffness"] > 0
    assert "workspace: verification margin" in run(*base).stdout
    bad = run("design", "stiffness", "--set", "device.mass=1", "--set", "device.damping=0", "--workspace", "nope",
              code=2)
    assert "requirements.workspace" in bad.stderr


@pytest.mark.slow
@pytest.mark.skipif(not has_route("/v1/design/inertia"),
                    reason="POST /v1/design/inertia is not in this build yet (branch inertia)")
def test_design_inertia_local_and_remote_are_identical():
    r = local_equals_remote("design", "inertia", "lhifam", "--set", "device.cable=null",
                            "--set", "requirements.pareto_points=3", "--margin", "6")
    assert r["status"] == "optimal" and r["apparent_mass"] < 5.4
    assert "inertia design" in run("design", "inertia", "lhifam", "--set", "device.cable=null",
                                   "--set", "requirements.pareto_points=3").stdout


@pytest.mark.skipif(not has_route("/v1/analysis/force-feedforward"),
                    reason="POST /v1/analysis/force-feedforward is not in this build yet (branch inertia)")
def test_feedforward_local_and_remote_are_identical():
    r = local_equals_remote("feedforward", "lhifam", "--set", "device.cable=null", "--cutoff-hz", "30")
    assert r["critical_force_gain"] > 0 and r["model"] == "rigid"
    assert "force feedforward" in run("feedforward", "lhifam").stdout


# ------------------------------------------------------------------------------------------------ simulate
SCENE = ("--experiment", "release", "--duration", "0.5", "--position", "1e-3")


def test_simulate_local_and_remote_are_identical():
    r = local_equals_remote("simulate", "lhifam", "--set", "device.cable=null", *SCENE, "--stiffness", "3000")
    assert r["verdict"]["state"] == "stable"
    assert "verdict" in run("simulate", "lhifam", "--set", "device.cable=null", *SCENE, "--stiffness", "3000").stdout


def test_simulate_above_the_critical_stiffness_exits_1(tmp_path):
    """Rigid LHifAM K_cr = 7000.756 N/m: a wall at 9000 N/m grows (scene given as a YAML file)."""
    (tmp_path / "scene.yaml").write_text("experiment: release\nduration: 2.0\ncontroller: {stiffness: 9000}\n"
                                         "initial: {position: 0.001}\n")
    r = run_json("simulate", "lhifam", "--set", "device.cable=null", "--scene-file", str(tmp_path / "scene.yaml"),
                 code=1)
    assert r["verdict"]["state"] == "unstable"


# ------------------------------------------------------------------------------------------------ plot
@pytest.mark.slow
def test_plot_simulation(tmp_path):
    out = tmp_path / "sim.svg"
    run("plot", "simulation", "lhifam", "--set", "device.cable=null", *SCENE, "--stiffness", "3000", "-o", str(out))
    assert b"<svg" in out.read_bytes()[:500]
    run("plot", "simulation", "lhifam", *SCENE, "-o", str(tmp_path / "x.gif"), code=2)


@pytest.mark.slow
@pytest.mark.skipif(not has_route("/v1/plots/boundary"),
                    reason="POST /v1/plots/boundary is not in this build yet (branch service)")
def test_plot_boundary(tmp_path):
    out = tmp_path / "b.png"
    r = run("plot", "boundary", "lhifam", "--points", "10", "-o", str(out))
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and str(out) in r.stdout


@pytest.mark.slow
@pytest.mark.skipif(not has_route("/v1/plots/bode"),
                    reason="POST /v1/plots/bode is not in this build yet (branch service)")
def test_plot_bode(tmp_path):
    out = tmp_path / "bode.svg"
    run("plot", "bode", "lhifam", "--stiffness", "3500", "--damping", "5", "--points", "50", "-o", str(out))
    assert b"<svg" in out.read_bytes()[:500]


# ------------------------------------------------------------------------------------------------ serve, bench
@pytest.mark.slow
def test_serve_is_the_session_server(server):
    """The session server was started with `python -m clients.cli serve --host … --port …` (conftest)."""
    assert server.process.args[1:4] == ["-m", "clients.cli", "serve"]
    assert json.loads(run("presets", "--json", "--url", server.url).stdout)


def test_bench_commands_pass_their_options(monkeypatch, tmp_path):
    """Wiring only: the benchmarks themselves are run (tiny versions) by tests/bench."""
    import bench.accuracy_vs_time
    import bench.bench_core

    seen = {}
    monkeypatch.setattr(bench.accuracy_vs_time, "main", lambda argv: seen.setdefault("accuracy", argv))
    monkeypatch.setattr(bench.bench_core, "main", lambda argv: seen.setdefault("core", argv))
    run("bench", "accuracy", "--quick", "--repeats", "2", "--out", str(tmp_path / "a.md"))
    run("bench", "core", "--repeats", "3", "--out", str(tmp_path / "c.md"))
    assert seen == {"accuracy": ["--quick", "--repeats", "2", "--out", str(tmp_path / "a.md")],
                    "core": ["--repeats", "3", "--out", str(tmp_path / "c.md")]}


@pytest.mark.slow
@pytest.mark.skipif(not has_route("/v1/studies"), reason="POST /v1/studies is not in this build yet (branch studies)")
def test_plot_study(server, tmp_path):
    import time

    from clients import ZwidthClient

    with ZwidthClient(server.url) as zw:
        created = zw.submit_study({"problem": "stability", "base": {"device": {"mass": 5.4, "damping": 3.5}},
                                   "sweep": {"device.delay": [0.0, 0.001, 0.002]}})
        deadline = time.monotonic() + 60
        while (st := zw.study(created.id)).status in ("queued", "running") and time.monotonic() < deadline:
            time.sleep(0.2)
        assert st.status == "done" and st.done == 3
        rows = zw.study_results(created.id).rows
    assert len(rows) == 3
    out = tmp_path / "study.svg"
    run("plot", "study", created.id, "--y", "critical_stiffness", "--x", "device.delay", "-o", str(out))
    assert b"<svg" in out.read_bytes()[:500]
    r = run("plot", "study", created.id, "--y", "nonsense", "--x", "device.delay", "-o", str(out), code=2)
    assert "y" in r.stderr


def test_serve_shares_the_cores_among_uvicorn_workers():
    from clients.cli import compute_workers_per_server

    assert compute_workers_per_server(2, 2) == 1        # 2 cores, --workers 2: one compute process each
    assert compute_workers_per_server(2, 8) == 4
    assert compute_workers_per_server(4, 2) == 1        # never below one
    assert compute_workers_per_server(3, None) == 1     # cpu_count unknown
