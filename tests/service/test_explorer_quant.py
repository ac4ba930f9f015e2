"""The explorer's issue-31 parts (service/explorer/explorer_quant.js) in headless Chromium against a live server:
the regime band on the boundary plot for a device with an encoder and friction, and the encoder answer of the
hardware tab with its counts over the travel.  Reference values by hand (Abbott & Okamura 2005): m = 0.2 kg,
b = 25 N·s/m, T = 1 ms, f_c = 0.1 N, q = 10 µm: 2b/T = 50 kN/m, 2f_c/q = 20 kN/m; for 20 kN/m the coarsest encoder is
2f_c/K_t = 10 µm, 10,000 counts over 100 mm."""

from __future__ import annotations

import pytest

from .conftest import start_live_server
from .test_explorer import _Browser, _require_browser


@pytest.mark.slow
@pytest.mark.e2e
def test_regime_band_and_encoder_answer(tmp_path):
    sync_api = _require_browser()
    expect = sync_api.expect
    server = start_live_server({"ZWIDTH_PRESTART_WORKERS": "false",
                                "ZWIDTH_DATABASE_URL": f"sqlite:///{tmp_path / 'studies.db'}"})
    try:
        with sync_api.sync_playwright() as p:
            b = _Browser(p, server.url)
            try:
                page = b.page
                page.goto(server.url + "/")
                page.select_option("#preset", "")
                page.check("#model-rigid")
                for field, value in (("#mass", "0.2"), ("#damping", "25"), ("#sample_time_ms", "1"),
                                     ("#delay_ms", "0"), ("#encoder_um", "10"), ("#coulomb_friction", "0.1"),
                                     ("#travel_mm", "100")):
                    page.fill(field, value)
                expect(page.locator("#regime-legend")).to_contain_text("passive", timeout=120_000)
                assert page.locator("#boundary-chart svg .regime-band rect[data-regime=passive]").count() >= 1

                page.click("#tab-hardware")
                page.select_option("#hw-free", "encoder_resolution")
                page.fill("#hw-stiffness", "20000")
                page.click("#hw-run")
                expect(page.locator("#hardware-encoder")).to_have_text("10.00 µm per count", timeout=60_000)
                expect(page.locator("#hardware-counts")).to_have_text("10000.0")
                expect(page.locator("#hardware-confirmed")).to_contain_text("yes")
                assert not b.errors, b.errors
            finally:
                b.close()
    finally:
        server.stop()
