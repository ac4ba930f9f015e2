"""The MATLAB/Octave client (clients/matlab) under GNU Octave, against the real server process.

Octave's own webwrite (7.x) cannot send a JSON body (it form-encodes its DATA and
drops a lone string), so under Octave the client sends through curl; the 'web'
transport (webread/webwrite, MATLAB's path) is exercised for GET.  The numbers
Octave decodes are compared with the Python client's for the same request.
"""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest

from clients import ZwidthClient

from .conftest import ROOT

OCTAVE = shutil.which("octave-cli")
pytestmark = [pytest.mark.slow, pytest.mark.skipif(OCTAVE is None, reason="octave-cli is not installed "
                                                   "(scripts/system-deps.sh installs Debian's octave package)")]
MATLAB_DIR = ROOT / "clients" / "matlab"


def octave(script: str, tmp_path: Path, url: str | None = None, check: bool = True) -> subprocess.CompletedProcess:
    """Run an Octave script with the client on the path; stdout is what the script printed."""
    path = tmp_path / "run_test.m"
    path.write_text(f"1;\nwarning('off', 'all');\naddpath('{MATLAB_DIR}');\n{script}\n")
    env = {"PATH": "/usr/bin:/bin", "HOME": str(tmp_path)}
    if url:
        env["ZWIDTH_URL"] = url
    proc = subprocess.run([OCTAVE, "--no-gui", "--norc", "--quiet", str(path)], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=120)
    if check:
        assert proc.returncode == 0, proc.stderr
    return proc


def numbers(text: str) -> list[float]:
    return [float(x) for x in text.split()]


def same_doubles(octave_values: list[float], python_values: list[float]) -> bool:
    """Equal to within the rounding of Octave's JSON reader.

    Octave's jsondecode uses RapidJSON's default (fast) number parser, which is not
    correctly rounded: measured here it lands 1 ulp off on some values (12180.508652429831
    for the server's 12180.508652429833).  Python parses JSON correctly rounded.  rtol=1e-15
    allows a few ulp and nothing more; printing with %.17g loses nothing.
    """
    return len(octave_values) == len(python_values) and all(
        o == pytest.approx(p, rel=1e-15, abs=0) for o, p in zip(octave_values, python_values))


def test_analyze_decodes_the_same_numbers_as_the_python_client(server, tmp_path):
    dev, wall = {"preset": "lhifam", "delay": 0.001}, {"stiffness": 3500.0, "damping": 5.0}
    p = octave("r = zwidth_analyze(struct('preset', 'lhifam', 'delay', 1e-3), struct('stiffness', 3500, 'damping', 5));\n"
               "printf('%.17g %.17g %.17g %d %d\\n', r.critical_stiffness, r.gain_margin_db, "
               "r.crossover_frequency, r.stable, numel(r.crossovers));", tmp_path, server.url)
    with ZwidthClient(server.url) as zw:
        r = zw.stability(dev, wall)
    assert same_doubles(numbers(p.stdout),
                        [r.critical_stiffness, r.gain_margin_db, r.crossover_frequency, 1, len(r.crossovers)])


def test_design_and_boundary(server, tmp_path):
    p = octave("d = zwidth_design_stiffness(struct('preset', 'lhifam', 'delay', 1e-3), "
               "struct('min_gain_margin_db', 6));\n"
               "b = zwidth_boundary(struct('preset', 'lhifam', 'delay', 1e-3), struct('points', 7));\n"
               "printf('%s\\n', d.status);\n"
               "printf('%.17g ', d.stiffness, d.damping, d.gain_margin_db); printf('\\n');\n"
               "printf('%.17g ', [b.points.critical_stiffness]); printf('\\n');", tmp_path, server.url)
    status, design, curve = p.stdout.strip().splitlines()
    with ZwidthClient(server.url) as zw:
        d = zw.design_stiffness({"preset": "lhifam", "delay": 0.001}, {"min_gain_margin_db": 6})
        b = zw.boundary({"preset": "lhifam", "delay": 0.001}, points=7)
    assert status == "optimal"
    assert same_doubles(numbers(design), [d.stiffness, d.damping, d.gain_margin_db])
    assert same_doubles(numbers(curve), [pt.critical_stiffness for pt in b.points])


def test_422_is_a_validation_error_naming_the_field(server, tmp_path):
    p = octave("try\n  zwidth_analyze(struct('mass', 5.4, 'damping', 3.5, 'delay', -1));\n"
               "catch e\n  printf('%s\\n%s\\n', e.identifier, e.message);\nend", tmp_path, server.url)
    ident, message = p.stdout.strip().split("\n", 1)
    assert ident == "zwidth:validation"
    assert "device.delay: Input should be greater than or equal to 0" in message


def test_connection_refused_is_retried_then_a_transport_error(dead_url, tmp_path):
    p = octave(f"try\n  zwidth_analyze(struct('preset', 'lhifam'), [], struct('url', '{dead_url}'));\n"
               "catch e\n  printf('%s\\n%s\\n', e.identifier, e.message);\nend", tmp_path)
    ident, message = p.stdout.strip().split("\n", 1)
    assert ident == "zwidth:transport" and "after 3 attempts" in message and dead_url in message


def test_the_request_it_sends(tmp_path):
    """A mock transport (a function handle) sees the request: method, URL, bearer token, JSON body."""
    p = octave("function resp = mock(req)\n"
               "  printf('%s %s\\n', req.method, req.url);\n"
               "  for i = 1:size(req.headers, 1), printf('%s: %s\\n', req.headers{i, 1}, req.headers{i, 2}); end\n"
               "  printf('timeout %g\\n', req.timeout);\n"
               "  printf('BODY %s\\n', req.body);\n"
               "  resp = struct('status', 200, 'body', '{\"status\": \"optimal\"}', 'message', '', 'refused', false);\n"
               "end\n"
               "opts = struct('url', 'http://lab:9000/', 'token', 's3cret', 'transport', @mock);\n"
               "d = zwidth_design_stiffness(struct('preset', 'lhifam', 'delay', 3e-3), "
               "struct('min_gain_margin_db', 10, 'passivity', true), opts);\n"
               "printf('STATUS %s\\n', d.status);", tmp_path)
    lines = p.stdout.strip().splitlines()
    assert lines[0] == "POST http://lab:9000/v1/design/stiffness"
    assert "Authorization: Bearer s3cret" in lines and "Content-Type: application/json" in lines
    assert "timeout 180" in lines                           # a design's own timeout
    body = json.loads(next(x for x in lines if x.startswith("BODY "))[5:])
    assert body == {"device": {"preset": "lhifam", "delay": 0.003},
                    "requirements": {"min_gain_margin_db": 10, "passivity": True}}
    assert lines[-1] == "STATUS optimal"


def test_web_transport_reads_with_webread(server, tmp_path):
    p = octave("h = zwidth_request('GET', '/healthz', [], struct('transport', 'web'));\n"
               "p = zwidth_request('GET', '/v1/presets', [], struct('transport', 'web'));\n"
               "printf('%s %g\\n', h.status, p.lhifam.cable.stiffness);", tmp_path, server.url)
    assert p.stdout.split() == ["ok", "79500"]


def test_example_designs_the_lhifam_wall_and_plots_the_boundary(server, tmp_path):
    p = octave(f"figure_file = '{tmp_path / 'wall.png'}';\nexample_lhifam_wall", tmp_path, server.url)
    with ZwidthClient(server.url) as zw:
        d = zw.design_stiffness({"preset": "lhifam", "delay": 0.001}, {"min_gain_margin_db": 6})
    assert f"K = {d.stiffness:.1f} N/m, B = {d.damping:.2f} N*s/m" in p.stdout
    assert "independent check: stable = 1, gain margin 6.00 dB" in p.stdout
    assert (tmp_path / "wall.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_identify_decodes_the_same_device_as_the_python_client(server, tmp_path):
    """zwidth_identify on a measured X/F (a rigid 5.4 kg device with 1.5 ms of delay, exact data)."""
    import numpy as np

    from models.device import Device
    from optim.identification.models import response

    w = np.geomspace(6.0, 2000.0, 12)
    h = response(Device(mass=5.4, damping=3.5, delay=0.0015), w, "continuous")
    vec = lambda v: "[" + " ".join(f"{x:.17g}" for x in v) + "]"  # noqa: E731
    p = octave(f"r = zwidth_identify(struct('kind', 'frequency_response', 'frequency', {vec(w)}, 'real', "
               f"{vec(h.real)}, 'imag', {vec(h.imag)}), struct('model', 'rigid'));\n"
               "printf('%s\\n', r.status); printf('%.17g ', [r.device.mass, r.device.damping, r.device.delay, "
               "r.uncertainty.device_mass.min, r.uncertainty.device_mass.max]); printf('\\n');",
               tmp_path, server.url)
    status, values = p.stdout.splitlines()[-2:]
    assert status == "identified"
    data = {"kind": "frequency_response", "frequency": w.tolist(), "real": h.real.tolist(), "imag": h.imag.tolist()}
    with ZwidthClient(server.url) as zw:
        r = zw.identify(data, model="rigid")
    py = [r.device["mass"], r.device["damping"], r.device["delay"], r.uncertainty["device.mass"].min,
          r.uncertainty["device.mass"].max]
    assert numbers(values) == pytest.approx(py, rel=1e-9)
    assert r.device["mass"] == pytest.approx(5.4, rel=1e-9)


def test_workspace_decodes_the_same_numbers_as_the_python_client(server, tmp_path):
    dev = {"sample_time": 1e-3, "delay": 1e-3, "kinematics": {"preset": "planar-2link"}}
    p = octave("dev = struct('sample_time', 1e-3, 'delay', 1e-3, 'kinematics', struct('preset', 'planar-2link'));\n"
               "r = zwidth_workspace(dev, struct('explicit', {{[0.3, 1.0]}}), {[0, 1, 0]});\n"
               "printf('%.17g %.17g\\n', r.minimum_critical_stiffness, r.worst.effective_mass);", tmp_path,
               url=server.url)
    with ZwidthClient(server.url) as zw:
        want = zw.workspace(dev, {"explicit": [[0.3, 1.0]]}, [[0, 1, 0]])
    assert same_doubles(numbers(p.stdout), [want.minimum_critical_stiffness, want.worst.effective_mass])


def test_filter_example_prints_the_python_clients_numbers(server, tmp_path):
    """example_lhifam_filter: the rendered wall (controller struct with velocity_filter and mass) through
    zwidth_analyze and zwidth_boundary, the same numbers as the Python client."""
    p = octave(f"figure_file = '{tmp_path / 'filter.svg'}';\nexample_lhifam_filter", tmp_path, server.url)
    dev = {"mass": 5.4, "damping": 3.5, "sample_time": 1e-3}
    lp = {"kind": "low_pass", "cutoff_hz": 50, "order": 1}
    with ZwidthClient(server.url) as zw:
        f = zw.stability(dev, {"stiffness": 2e4, "damping": 50, "mass": 0.5, "velocity_filter": lp})
        b1 = zw.boundary(dev, {"velocity_filter": lp}, points=60)
    assert (f"low-pass 50 Hz:      K_cr = {f.critical_stiffness:.1f} N/m, B_max = {f.max_stable_damping:.1f} N*s/m, "
            f"M-width [{f.mass_range.min:.4g}, {f.mass_range.max:.4g}] kg") in p.stdout
    assert f"{b1.optimum.critical_stiffness:.1f} N/m at B = {b1.optimum.damping:.1f} (50 Hz)" in p.stdout
    assert (tmp_path / "filter.svg").exists()


def test_the_encoder_and_friction_travel_in_the_device_struct(tmp_path):
    """Issue 31: encoder_resolution / coulomb_friction / travel go out in the device struct, and the hardware
    design's free parameter as asked (a mock transport sees the body)."""
    p = octave("function resp = mock(req)\n"
               "  printf('BODY %s\\n', req.body);\n"
               "  resp = struct('status', 200, 'body', '{\"status\": \"optimal\", \"value\": 1e-05, "
               "\"quantisation\": {\"counts_over_travel\": 10000}}', 'message', '', 'refused', false);\n"
               "end\n"
               "dev = struct('mass', 0.2, 'damping', 25, 'encoder_resolution', 1e-5, 'coulomb_friction', 0.1, "
               "'travel', 0.1);\n"
               "h = zwidth_design_hardware(dev, struct('stiffness', 2e4), 'encoder_resolution', "
               "struct('transport', @mock));\n"
               "printf('ANSWER %.17g %.17g\\n', h.value, h.quantisation.counts_over_travel);", tmp_path)
    lines = p.stdout.strip().splitlines()
    body = json.loads(next(x for x in lines if x.startswith("BODY "))[5:])
    assert body == {"device": {"mass": 0.2, "damping": 25, "encoder_resolution": 1e-5, "coulomb_friction": 0.1,
                               "travel": 0.1}, "target": {"stiffness": 20000}, "free": "encoder_resolution"}
    assert lines[-1] == "ANSWER 1.0000000000000001e-05 10000"


def test_example_encoder_friction_answers_the_encoder_20_kn_per_m_needs(server, tmp_path):
    p = octave("example_encoder_friction", tmp_path, server.url)
    # 2f_c/q = 2·0.1/1e-5 = 20 kN/m ≥ 15 kN/m and 2b/T = 50 kN/m: passive (Abbott & Okamura); q* = 2f_c/K_t = 10 µm
    assert "K = 15 kN/m: regime passive" in p.stdout
    assert "20 kN/m needs q <= 1e-05 m per count: 10000 counts over the 0.10 m travel (checked: 1)" in p.stdout


def test_design_stiffness_over_a_workspace(server, tmp_path):
    """requirements.workspace passes through zwidth_design_stiffness as a struct: the same design as the client's."""
    dev = {"mass": 1, "damping": 0, "sample_time": 1e-3, "delay": 1e-3}
    ws = {"kinematics": {"preset": "planar-2link"}, "poses": {"latin_hypercube": {"samples": 3, "seed": 3}},
          "normals": "worst", "verify_factor": 1}
    p = octave("ws = struct('kinematics', struct('preset', 'planar-2link'), 'poses', "
               "struct('latin_hypercube', struct('samples', 3, 'seed', 3)), 'normals', 'worst', 'verify_factor', 1);\n"
               "r = zwidth_design_stiffness(struct('mass', 1, 'damping', 0, 'sample_time', 1e-3, 'delay', 1e-3), "
               "struct('min_gain_margin_db', 1, 'workspace', ws));\n"
               "printf('%s\\n', r.status);\n"
               "printf('%.17g %.17g %.17g\\n', r.stiffness, r.damping, r.workspace.verification_margin);", tmp_path,
               url=server.url)
    status, values = p.stdout.strip().splitlines()
    with ZwidthClient(server.url) as zw:
        want = zw.design_stiffness(dev, {"min_gain_margin_db": 1, "workspace": ws})
    assert status == want.status == "optimal"
    assert numbers(values)[:2] == pytest.approx([want.stiffness, want.damping], rel=1e-7)
    assert numbers(values)[2] == pytest.approx(want.workspace.verification_margin, rel=1e-6)
