"""Interactive docs work offline: assets from a package, examples for every operation, and a real
headless Chromium that renders the operations while every non-loopback host fails to resolve."""

from __future__ import annotations

import re
import shutil
import subprocess
import tempfile
from pathlib import Path

import pytest

from .conftest import start_live_server

CHROMIUM = "/usr/bin/chromium"


@pytest.mark.slow
def test_docs_pages_reference_only_local_assets(client):
    for path in ("/docs", "/redoc"):
        html = client.get(path).text
        urls = re.findall(r"""(?:src|href)\s*=\s*['"]([^'"]+)['"]""", html) + re.findall(r"url:\s*'([^']+)'", html)
        assert urls, path
        for url in urls:
            assert not url.startswith(("http:", "https:", "//")), (path, url)
            assert client.get(url).status_code == 200, (path, url)
        assert "cdn" not in html.lower() and "fonts.googleapis" not in html


def test_favicon_is_served_locally(client):
    r = client.get("/favicon.ico")
    assert r.status_code == 200 and r.content.startswith(b"\x89PNG")


def _body_examples(schema: dict, op: dict) -> list:
    """Examples of an operation's JSON body: named requestBody examples, or the body schema's own."""
    content = op["requestBody"]["content"]["application/json"]
    named = [e["value"] for e in (content.get("examples") or {}).values()]
    ref = content.get("schema", {}).get("$ref", "")
    component = schema["components"]["schemas"].get(ref.rsplit("/", 1)[-1], {}) if ref else content.get("schema", {})
    return named + list(component.get("examples") or [])


MINE = {"/v1/analysis/stability", "/v1/analysis/boundary", "/v1/plots/boundary", "/v1/plots/bode"}


def test_every_operation_has_examples_and_an_operation_id(client):
    schema = client.get("/openapi.json").json()
    ops = [(path, method, op) for path, item in schema["paths"].items() for method, op in item.items()]
    assert {p for p, _, _ in ops} >= {"/healthz", "/v1/presets"} | MINE
    for path, method, op in ops:
        assert op.get("operationId"), path
        if "requestBody" in op:
            examples = _body_examples(schema, op)
            assert examples, path
            if path in MINE:  # named examples in Swagger UI's menu: the presets at least
                assert len(op["requestBody"]["content"]["application/json"]["examples"]) >= 3, path
                assert any("preset" in str(e) for e in examples), path
        else:
            content = op["responses"]["200"]["content"]
            if "application/json" in content:
                ok = content["application/json"]
                assert "example" in ok or "examples" in ok or "$ref" in ok.get("schema", {}), path
            else:  # a figure or a file: its media types declare what comes back
                assert all(c.get("schema", {}).get("format") == "binary" for c in content.values()), path


@pytest.mark.slow
def test_every_example_is_accepted_by_its_endpoint(client):
    """The documented examples are not decoration: each one answers 200."""
    schema = client.get("/openapi.json").json()
    for path in sorted(MINE):
        op = schema["paths"][path]["post"]
        for i, example in enumerate(_body_examples(schema, op)):
            r = client.post(path, json=example)
            assert r.status_code == 200, (path, i, r.text[:300])


def _chromium_dom(url: str) -> str:
    with tempfile.TemporaryDirectory() as profile:
        cmd = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
               "--disable-background-networking", "--disable-component-update", "--disable-sync",
               "--disable-dev-shm-usage",
               # Offline for real: every host but loopback fails to resolve, so a CDN fetch would fail.
               "--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE 127.0.0.1",
               f"--user-data-dir={profile}", "--virtual-time-budget=15000", "--dump-dom", url]
        out = subprocess.run(cmd, capture_output=True, timeout=120, check=False)
    assert out.returncode == 0, out.stderr.decode(errors="replace")[-2000:]
    return out.stdout.decode(errors="replace")


@pytest.mark.slow
@pytest.mark.e2e
def test_swagger_ui_renders_the_operations_in_headless_chromium():
    """Fails loudly (never skips) without Chromium: scripts/system-deps.sh installs it for the test run."""
    if not Path(CHROMIUM).exists():
        found = shutil.which("chromium")
        pytest.fail(f"{CHROMIUM} is missing (which: {found}); run scripts/system-deps.sh (apt-get install chromium)")
    server = start_live_server({"ZWIDTH_PRESTART_WORKERS": "false"})
    try:
        dom = _chromium_dom(server.url + "/docs")
        redoc = _chromium_dom(server.url + "/redoc")
    finally:
        server.stop()
    assert "swagger-ui" in dom
    # Rendered operation blocks (Swagger UI builds them from /openapi.json at run time).
    for op_id in ("analyse_stability", "stability_boundary", "plot_bode", "plot_boundary", "list_presets", "healthz"):
        assert "operations-" in dom and op_id in dom, op_id
    for path in ("/v1/analysis/stability", "/v1/analysis/boundary", "/v1/plots/bode", "/healthz"):
        assert path in dom, path
    assert "/v1/analysis/stability" in redoc and "Critical stiffness" in redoc
