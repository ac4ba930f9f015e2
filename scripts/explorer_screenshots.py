"""Screenshots of every panel of the design explorer at 1280 × 900, and docs/explorer.md around them.

Run: ``python scripts/explorer_screenshots.py`` (needs the test extras and /usr/bin/chromium, as the tests do).
It starts a live server on loopback with a throw-away study store, drives each panel as a user would, and writes
docs/explorer/*.png and docs/explorer.md.  Nothing in the page is typed by hand into the docs: the figures and the
values quoted under them are read from the rendered page.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.live_server import LiveServer  # noqa: E402

OUT = ROOT / "docs" / "explorer"
CHROMIUM = "/usr/bin/chromium"


def _panels(page, expect, tmp: Path) -> list[tuple[str, str, str]]:
    """Drives each panel; returns (file, title, what the page showed)."""
    shots = []

    def shot(name: str, title: str, said: str) -> None:
        page.screenshot(path=str(OUT / f"{name}.png"), full_page=False)
        shots.append((f"explorer/{name}.png", title, said))

    page.select_option("#preset", "lhifam")
    expect(page.locator("#kcr-rigid")).to_contain_text("N/m", timeout=60_000)
    page.mouse.move(700, 500)
    shot("boundary", "Boundary", f"K_cr (cable) {page.inner_text('#kcr')}, rigid model {page.inner_text('#kcr-rigid')}, "
                                 f"B_max {page.inner_text('#bmax')}")

    page.fill("#delay_ms", "1")
    page.click("#tab-stiffness")
    page.click("#st-run")
    expect(page.locator("#stiffness-K")).to_contain_text("N/m", timeout=60_000)
    shot("stiffness", "Stiffest wall (1 ms delay, 6 dB)",
         f"K {page.inner_text('#stiffness-K')}, B {page.inner_text('#stiffness-B')}, "
         f"limited by {page.inner_text('#stiffness-limit')}")

    page.fill("#delay_ms", "0")
    page.click("#tab-inertia")
    page.click("#in-run")
    expect(page.locator("#inertia-status")).to_be_visible(timeout=120_000)
    shot("inertia", "Lightest feel", f"status {page.inner_text('#inertia-status')}, K_f {page.inner_text('#inertia-Kf')}, "
                                     f"cutoff {page.inner_text('#inertia-cutoff')}, "
                                     f"apparent mass {page.inner_text('#inertia-mass')}")

    # The default box follows the model: the cable device's body damping b_d (device.damping is refused there).
    page.click("#tab-robust")
    page.click("#rb-run")
    expect(page.locator("#robust-status")).to_be_visible(timeout=180_000)
    shot("robust_cable", "Robust wall over the cable model's default box (LHifAM, delay 0.5–1.5 ms, b_d ± 1/7)",
         f"box {' '.join(page.input_value('#rb-box').split())}; status {page.inner_text('#robust-status')}, "
         f"K {page.inner_text('#robust-K')}")

    cable_k = page.inner_text("#robust-K")
    page.check("#model-rigid")
    page.click("#rb-run")
    expect(page.locator("#robust-K")).to_be_visible(timeout=120_000)
    expect(page.locator("#robust-K")).not_to_have_text(cable_k, timeout=120_000)
    shot("robust", "Robust wall over a box (rigid LHifAM, delay 0.5–1.5 ms, b 3–4 N·s/m)",
         f"status {page.inner_text('#robust-status')}, K {page.inner_text('#robust-K')}")

    page.click("#tab-hardware")
    page.fill("#hw-stiffness", "3000")
    page.click("#hw-run")
    expect(page.locator("#hardware-status")).to_be_visible(timeout=120_000)
    shot("hardware", "Delay budget for a 3 kN/m wall (rigid LHifAM)",
         f"status {page.inner_text('#hardware-status')}, loosest delay {page.inner_text('#hardware-value')}")

    # The issue-29 case: the LHifAM (cable) at 1 ms of delay with K = 3 kN/m, its delay, cable and sensor
    # filter simulated (the defaults), the hand left out and said so.
    page.select_option("#preset", "")
    page.select_option("#preset", "lhifam")     # the preset's cable model again
    page.fill("#delay_ms", "1")
    page.click("#tab-simulate")
    page.fill("#sim-stiffness", "3000")
    page.click("#sim-run")
    expect(page.locator("#simulate-plot")).to_be_visible(timeout=120_000)
    page.locator("#simulate-result").scroll_into_view_if_needed()
    shot("simulate", "Release from 1 mm inside a 3 kN/m wall (LHifAM, cable, 1 ms delay; delay, cable and "
                     "sensor filter simulated)",
         f"verdict {page.inner_text('#simulate-verdict')}; the wall's analysis "
         f"{' '.join(page.inner_text('#simulate-analysis').split())}; "
         f"{' '.join(page.inner_text('#simulate-warning').split())}")
    page.locator("#simulate-plot").scroll_into_view_if_needed()
    shot("simulate_plot", "Its figure (the service's plot: K, B and what was not simulated in the title)",
         "the same verdict, drawn by /v1/plots/simulation")
    page.check("#model-rigid")
    page.fill("#delay_ms", "0")

    page.click("#tab-studies")
    page.fill("#sd-mass-num", "4")
    page.fill("#sd-delay-num", "4")
    page.click("#sd-run")
    row = page.locator("#study-table tbody tr").first
    expect(row.locator(".progress-text")).to_have_text("16/16", timeout=120_000)
    row.get_by_role("button", name="heatmap").click()
    expect(page.locator("#study-plot")).to_be_visible(timeout=60_000)
    shot("studies", "A 16-point study (mass × delay) and its heatmap", f"progress {row.locator('.progress-text').inner_text()}")

    page.click("#tab-identify")
    page.set_input_files("#id-file", str(_identify_data(tmp)))
    page.click("#id-run")
    expect(page.locator("#identify-status")).to_be_visible(timeout=120_000)
    page.click("#id-robust")
    expect(page.locator("#id-robust-status")).to_be_visible(timeout=120_000)
    shot("identify", "Identification from a measured record, then the safe wall for its box",
         f"status {page.inner_text('#identify-status')}, robust wall {page.inner_text('#id-robust-K')} "
         f"({page.inner_text('#id-robust-status')})")
    return shots


def _identify_data(tmp: Path) -> Path:
    """A measured record of the rigid LHifAM (1.3 ms of delay, noise, quantisation) as the lab's CSV."""
    from tests.optim.identification.cases import record

    d = record("rigid", 0.0013)
    path = tmp / "measurement.csv"
    path.write_text("time,force,position\n" + "".join(
        f"{k * 0.001:.6f},{u!r},{y!r}\n" for k, (u, y) in enumerate(zip(d.force.tolist(), d.position.tolist()))))
    return path


def main() -> None:
    from playwright.sync_api import expect, sync_playwright

    OUT.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        server = LiveServer({"ZWIDTH_PRESTART_WORKERS": "false", "ZWIDTH_DATABASE_URL": f"sqlite:///{tmp}/s.db"},
                            timeout=60)
        try:
            with sync_playwright() as p:
                browser = p.chromium.launch(executable_path=CHROMIUM, args=[
                    "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                    "--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE 127.0.0.1"])
                page = browser.new_page(viewport={"width": 1280, "height": 900})
                page.goto(server.url + "/")
                shots = _panels(page, expect, Path(tmp))
                browser.close()
        finally:
            server.stop()
    lines = ["# The design explorer", "",
             "<!-- generated by scripts/explorer_screenshots.py; do not edit by hand -->", "",
             "`GET /` on a running server (e.g. <http://127.0.0.1:8000/>) serves one page for the lab: pick a "
             "preset or enter a device, watch the stability boundary move, design the stiffest wall and the "
             "lightest feel, a robust wall for a box, the hardware a target needs, simulate a scene, identify a "
             "device from a measurement, and run studies with live progress.", "",
             "* The page is static (service/explorer/: HTML, CSS, JS, no library, no CDN) and works offline.",
             "* Every number comes from the /v1 API, the calls any client makes; the page validates nothing itself: "
             "every 422 is shown as the field the API named and its message (beside the device field it names, "
             "or in the panel for a requirement, a box or a scene).",
             "* Simulate names the device's effects in the scene (/v1/simulate simulates only what a scene names): "
             "the loop delay, the cable mode and the force-sensor filter are ticked by default, the hand holding "
             "the handle when ticked (a release lets go of the handle, and the wall's analysis, K_cr, has no hand). "
             "Whatever the device has and the scene leaves out is said above the answer and in the figure's title, "
             "and the wall's own analysis (/v1/analysis/stability at the scene's K and B) is shown beside the "
             "verdict, with the reason when the two differ.",
             "* The Robust tab's default box follows the model: delay 0.5–1.5 ms and the damping ± 1/7 (rigid: "
             "`device.damping`; cable: `device.cable.body_damping`, since a cable device's damping is its two "
             "masses'). A box you edited is kept.",
             "* Curves that need hover (boundary, Pareto, hardware trade-off) are drawn in the page from the API's "
             "numbers; the simulation, identification and study figures are the service's own SVG plots, so a figure "
             "in the page and one fetched from /v1/plots are the same figure.",
             "* With `ZWIDTH_API_TOKEN` set, the page asks for the token once and keeps it in the tab's session "
             "storage only.",
             "* Keyboard: Tab through the form, arrow keys between panels; every input has a label and a unit.",
             "* Tested end to end in headless Chromium against a live server with every host but loopback "
             "unreachable (tests/service/test_explorer.py).", ""]
    for file, title, said in shots:
        lines += [f"## {title}", "", f"![{title}]({file})", "", f"The page showed: {said}.", ""]
    (ROOT / "docs" / "explorer.md").write_text("\n".join(lines))
    print("\n".join(f"{f}: {s}" for f, _, s in shots))


if __name__ == "__main__":
    main()
