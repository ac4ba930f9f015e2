"""Plots: real PNG/SVG files, drawn from exactly the numerics' arrays; the Bode data checked independently."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from models.device import PRESETS, Device
from models.plants import cable_tfs
from optim.stability.boundary import stability_boundary
from optim.stability.frequency_response import loop_frequency_response, plant_response
from service.plots import bode_figure, boundary_figure, render

from .conftest import LHIFAM_RIGID

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _line(fig, gid):
    for ax in fig.axes:
        for line in ax.get_lines():
            if line.get_gid() == gid:
                return line
    raise AssertionError(f"no line {gid}")


@pytest.mark.slow
@pytest.mark.parametrize("path,body", [
    ("/v1/plots/boundary", {"device": LHIFAM_RIGID, "points": 15}),
    ("/v1/plots/bode", {"device": {"preset": "lhifam"}, "controller": {"stiffness": 3000.0}}),
    ("/v1/plots/bode", {"device": {**LHIFAM_RIGID, "delay": 0.0123}, "points": 50}),
])
@pytest.mark.parametrize("fmt", ["png", "svg"])
def test_plot_routes_answer_real_images(client, path, body, fmt):
    r = client.post(path, json={**body, "format": fmt})
    assert r.status_code == 200, r.text[:300]
    if fmt == "png":
        assert r.headers["content-type"] == "image/png"
        assert r.content.startswith(PNG_MAGIC)
        width, height = int.from_bytes(r.content[16:20], "big"), int.from_bytes(r.content[20:24], "big")
        assert width >= 600 and height >= 400  # 6.4 in × 100 dpi
    else:
        assert r.headers["content-type"].startswith("image/svg+xml")
        root = ET.fromstring(r.content)  # well-formed XML
        assert root.tag == "{http://www.w3.org/2000/svg}svg"


@pytest.mark.slow
def test_default_format_is_png(client):
    r = client.post("/v1/plots/bode", json={"device": LHIFAM_RIGID})
    assert r.content.startswith(PNG_MAGIC)


@pytest.mark.slow
def test_svg_output_is_deterministic():
    res = loop_frequency_response(Device(**LHIFAM_RIGID), 0.0, 60)
    assert render(bode_figure(res), "svg") == render(bode_figure(res), "svg")


def test_boundary_figure_plots_the_numerics_arrays_exactly():
    device = Device(preset="lhifam")
    res = stability_boundary(device, None, 12)
    fig = boundary_figure(res)
    line = _line(fig, "boundary")
    assert np.array_equal(line.get_xdata(), [p.damping for p in res.points])
    assert np.array_equal(line.get_ydata(), [p.critical_stiffness for p in res.points], equal_nan=True)
    assert np.array_equal(_line(fig, "linear").get_ydata(), [p.linear_estimate for p in res.points])
    opt = _line(fig, "optimum")
    assert (opt.get_xdata()[0], opt.get_ydata()[0]) == (res.optimum.damping, res.optimum.critical_stiffness)


def test_bode_figure_plots_the_numerics_arrays_exactly():
    res = loop_frequency_response(Device(preset="lhifam"), 0.0, 120)
    fig = bode_figure(res, stiffness=3000.0)
    mag = _line(fig, "magnitude")
    assert np.array_equal(mag.get_xdata(), res.frequency)
    assert np.array_equal(mag.get_ydata(), 20 * np.log10(res.magnitude))
    assert np.array_equal(_line(fig, "phase").get_ydata(), res.phase_deg)
    marks = _line(fig, "crossovers")
    assert list(marks.get_xdata()) == [c.frequency for c in res.crossovers]
    assert list(marks.get_ydata()) == [20 * math.log10(c.magnitude) for c in res.crossovers]
    assert list(_line(fig, "crossovers-phase").get_ydata()) == [c.phase_deg for c in res.crossovers]
    assert _line(fig, "wall").get_ydata()[0] == -20 * math.log10(3000.0)


@pytest.mark.slow
def test_a_long_delay_marks_every_crossover_but_labels_the_binding_few():
    """Issue 18: a 1 s delay has hundreds of crossovers; a text per crossover made the drawing take a minute.
    All are marked (one artist), the MAX_CROSSOVER_LABELS of least K_i are labelled, the rest counted."""
    import time

    from service.plots import MAX_CROSSOVER_LABELS, labelled_crossovers

    res = loop_frequency_response(Device(**LHIFAM_RIGID, delay=1.0), 0.0, 2000)
    assert len(res.crossovers) > 10 * MAX_CROSSOVER_LABELS
    t0 = time.perf_counter()
    fig = bode_figure(res)
    png = render(fig, "png")
    assert png.startswith(PNG_MAGIC) and time.perf_counter() - t0 < 10
    assert len(_line(fig, "crossovers").get_xdata()) == len(res.crossovers)
    texts = [t.get_text() for t in fig.axes[0].texts]
    labelled = labelled_crossovers(res.crossovers)
    assert len(labelled) == MAX_CROSSOVER_LABELS
    assert [t for t in texts if t.endswith(" N/m")] == [f"{c.stiffness:.4g} N/m" for c in labelled]
    # the labelled ones are those of least K_i, and K_cr (the least of all) is among them
    worst_labelled = max(c.stiffness for c in labelled)
    assert sum(c.stiffness < worst_labelled for c in res.crossovers) < MAX_CROSSOVER_LABELS
    assert min(c.stiffness for c in labelled) == min(c.stiffness for c in res.crossovers)
    assert any(t.startswith(f"{len(res.crossovers)} crossovers") for t in texts)


@pytest.mark.parametrize("device", [Device(**LHIFAM_RIGID)] + [Device(preset=p) for p in sorted(PRESETS)]
                         + [Device(**LHIFAM_RIGID, delay=0.0042), Device(preset="lhifam", delay=0.0017)])
def test_crossovers_sit_where_the_phase_is_minus_180_and_the_gain_is_one_over_k(device):
    """Independent of how K_cr was found (bracketed root finding on -1/G): at B = 0 each crossover must be
    a point where G(e^{jωT}) is real and negative with |G| = 1/K_i, read off the frequency response."""
    res = loop_frequency_response(device, 0.0, 200)
    assert res.crossovers
    for c in res.crossovers:
        # rtol 1e-9: the crossovers are refined to a few ulp in ω; |G| moves by |dG/dω|·δω there.
        assert c.magnitude * c.stiffness == pytest.approx(1.0, rel=1e-9)
        assert math.remainder(c.phase_deg + 180.0, 360.0) == pytest.approx(0.0, abs=1e-6)
    # the binding crossover of the list and K_cr: the same root (the cable's bounded scan solves it on its own
    # bracket, the list on the scan's: they may differ in the last ulp)
    assert min(c.stiffness for c in res.crossovers) == pytest.approx(res.critical_stiffness, rel=4e-16)


def _control_response(device: Device, omega: np.ndarray) -> np.ndarray:
    """G(e^{jωT}) from python-control's ZOH discretisation (a second, independent algorithm), whole-sample delay."""
    control = pytest.importorskip("control")
    if device.cable is None:
        num, den = [1.0], [device.mass, device.damping, 0.0]
    else:
        g_r = cable_tfs(device)["G_r"]  # p_d/p; p(0) = 0 carries the free integrator
        num, den = list(g_r.num), list(g_r.den)
    sysd = control.sample_system(control.tf(num, den), device.sample_time, method="zoh")
    z = np.exp(1j * omega * device.sample_time)
    d = round(device.delay_samples)
    return np.array([sysd(zi) for zi in z]) * z ** (-d)


@pytest.mark.parametrize("device", [Device(**LHIFAM_RIGID), Device(preset="lhifam"), Device(preset="phantom-1.0"),
                                    Device(**LHIFAM_RIGID, delay=0.003)])
def test_plant_response_matches_python_control_zoh(device):
    """models' exact ZOH (closed form / augmented exponential) against python-control's c2d: same G(e^{jωT}).

    rtol 1e-6: python-control goes through scipy's cont2discrete and a transfer-function polynomial
    evaluation, which loses ~8 digits near the double pole at z = 1 (a cancellation zwidth avoids)."""
    omega = np.geomspace(0.05, math.pi * 0.999, 60) / device.sample_time
    mag, phase = plant_response(device, omega)
    ref = _control_response(device, omega)
    assert np.allclose(mag, np.abs(ref), rtol=1e-6, atol=0)
    # Compare phases as unit phasors: branches differ by multiples of 360°.
    assert np.allclose(np.exp(1j * np.radians(phase)), ref / np.abs(ref), rtol=0, atol=1e-6)


def test_phase_of_a_long_delay_is_continuous_and_has_the_delay_slope():
    """With 4000 samples of delay np.unwrap on a 400-point grid would guess; the delay term is analytic."""
    device = Device(**LHIFAM_RIGID, delay=4.0)
    res = loop_frequency_response(device, 0.0, 400)
    base = loop_frequency_response(Device(**LHIFAM_RIGID), 0.0, 400)
    theta = res.frequency * device.sample_time
    assert np.allclose(res.phase_deg, base.phase_deg - np.degrees(4000 * theta), rtol=0, atol=1e-6)
