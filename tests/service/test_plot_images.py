"""Plots checked by what matplotlib drew, not by magic bytes (issue 19).

Two views of each figure:
* every plot route's SVG: matplotlib writes each drawn text as an XML comment beside its glyphs, so the title,
  the axis labels and their units are read back from the file the client receives;
* the figure objects of the plot functions, drawn by Agg: every visible text's bounding box lies inside the
  figure (nothing clipped at an edge), and every axis label carries a unit in brackets.
The ``?format=`` convention (the query, on every plot route) is tested here too.
"""

from __future__ import annotations

import re
from html import unescape

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.text import Text

from models.device import Device
from optim.stability.boundary import stability_boundary
from optim.stability.frequency_response import loop_frequency_response
from service.plot_labels import (
    ROTARY,
    TRANSLATIONAL,
    base_device_title,
    device_title,
    path_label,
)
from service.plots import LOOP_MATH, bode_figure, boundary_figure
from service.studies.plot import check_y, study_figure

from .conftest import make_client

RIGID = {"mass": 5.4, "damping": 3.5, "sample_time": 0.001}
UNC = {"device.mass": {"min": 4, "max": 7}, "device.delay": {"min": 0, "max": 0.002}}
UNIT = re.compile(r"\[[^\]]+\]")


@pytest.fixture(scope="module")
def client():
    with make_client() as c:
        yield c


def _ts() -> dict:
    from tests.optim.identification.cases import (
        record,  # the identification tests' own recorded run
    )

    d = record("rigid", 0.0013)
    return {"kind": "time_series", "sample_time": 0.001, "force": d.force[:1500].tolist(),
            "position": d.position[:1500].tolist()}


#: route -> (body, texts the figure must show): the device named in the title, axis units present
ROUTES = {
    "boundary": ({"device": {"preset": "phantom-1.0"}, "points": 10},
                 ["phantom-1.0 (cable), t_d = 0 ms, T = 1 ms", "virtual damping B [N·m·s/rad]",
                  "critical stiffness $K_{cr}$ [N·m/rad]"]),
    "bode": ({"device": {**RIGID, "delay": 0.002}, "points": 60, "controller": {"stiffness": 3000.0}},
             ["m = 5.4 kg, b = 3.5 N·s/m (rigid), t_d = 2 ms, T = 1 ms", LOOP_MATH + ", B = 0 N·s/m",
              "|G| [dB re 1 m/N]", "phase [deg]", "ω [rad/s]", "3000 N/m"]),
    "simulation": ({"device": RIGID, "scene": {"experiment": "release", "duration": 0.3,
                                               "controller": {"stiffness": 3000}, "initial": {"position": 1e-3}}},
                   ["m = 5.4 kg, b = 3.5 N·s/m (rigid), t_d = 0 ms, T = 1 ms", "position [mm]", "force [N]",
                    "time [s]", "K = 3000 N/m, B = 0 N·s/m: ", "every block of the device simulated"]),
    # the box's delay is said as its range (issue 29: the title said "t_d = 0 ms" over a 0–2 ms axis)
    "robust": ({"device": {"preset": "lhifam", "cable": None}, "requirements": {"uncertainty": UNC}, "points": 7},
               ["lhifam (rigid), t_d = 0–2 ms, T = 1 ms; box: m = 4–7 kg", "mass m [kg]", "delay t_d [ms]",
                "gain margin [dB]"]),
    "hardware": ({"device": {"preset": "lhifam", "cable": None}, "target": {"stiffness": 2e5}, "free": "delay",
                  "points": 9},
                 ["lhifam (rigid), t_d free, T = 1 ms", "delay t_d [ms]", "$K^*$ [N/m]"]),
    "identify": ({"model": "rigid"}, ["(rigid)", "T = 1 ms", "position [mm]", "residual [µm]", "time [s]"]),
}


def _texts(svg: bytes) -> list[str]:
    """The texts matplotlib drew into an SVG (each is written as a comment before its glyphs)."""
    return [unescape(t) for t in re.findall(r"<!-- (.*?) -->", svg.decode(), flags=re.S)]


def _body(route: str) -> dict:
    body = dict(ROUTES[route][0])
    if route == "identify":
        body["data"] = _ts()
    return body


@pytest.mark.slow
@pytest.mark.parametrize("route", list(ROUTES))
def test_every_plot_route_draws_title_device_and_units(client, route):
    r = client.post(f"/v1/plots/{route}", params={"format": "svg"}, json=_body(route))
    assert r.status_code == 200, r.text[:300]
    assert r.headers["content-type"].startswith("image/svg+xml")
    drawn = _texts(r.content)
    joined = "\n".join(drawn)
    for text in ROUTES[route][1]:
        assert text in joined, (text, drawn)
    assert not any(re.search(r"\b(device|requirements)\.\w", t) for t in drawn), drawn  # no dotted names


@pytest.mark.slow
@pytest.mark.parametrize("route", list(ROUTES))
def test_format_is_a_query_parameter_on_every_plot_route(client, route):
    """One convention: ?format=png|svg (png by default) on every plot route; a bad value names the field."""
    body = _body(route)
    png = client.post(f"/v1/plots/{route}", json=body)
    assert png.status_code == 200 and png.headers["content-type"] == "image/png"
    bad = client.post(f"/v1/plots/{route}", params={"format": "gif"}, json=body)
    assert bad.status_code == 422 and "format" in bad.text


@pytest.mark.slow
def test_body_format_still_accepted_where_it_was_and_the_query_wins(client):
    """The body's format of boundary, bode and identify is accepted for one release (deprecated)."""
    body = {"device": RIGID, "points": 20}
    assert client.post("/v1/plots/bode", json={**body, "format": "svg"}).headers["content-type"].startswith(
        "image/svg+xml")
    r = client.post("/v1/plots/bode", params={"format": "png"}, json={**body, "format": "svg"})
    assert r.headers["content-type"] == "image/png"
    schema = client.get("/openapi.json").json()
    for name in ("plot_boundary", "plot_bode"):
        op = next(o for p in schema["paths"].values() for o in p.values() if o.get("operationId") == name)
        assert any(q["name"] == "format" and q["in"] == "query" for q in op["parameters"])


# ------------------------------------------------------------------------- figure objects: boxes and units
def _drawn_texts(fig) -> list[Text]:
    if not isinstance(fig.canvas, FigureCanvasAgg):
        FigureCanvasAgg(fig)
    fig.canvas.draw()
    return [t for t in fig.findobj(Text) if t.get_visible() and t.get_text().strip()]


def _assert_inside(fig) -> None:
    """Every text drawn lies inside the figure: the figure's tight box (what was drawn, ticks outside the view
    left out) within its own box, and each title, label, legend and annotation one by one."""
    texts = _drawn_texts(fig)
    renderer = fig.canvas.get_renderer()
    tight, box = fig.get_tightbbox(renderer), fig.bbox_inches
    assert tight.x0 >= box.x0 - 0.01 and tight.y0 >= box.y0 - 0.01 and tight.x1 <= box.x1 + 0.01 \
        and tight.y1 <= box.y1 + 0.01, (tight, box)
    ticks = {id(lab) for ax in fig.axes for axis in (ax.xaxis, ax.yaxis)
             for tick in axis.get_major_ticks() + axis.get_minor_ticks() for lab in (tick.label1, tick.label2)}
    for t in texts:
        if id(t) in ticks:
            continue
        ext = t.get_window_extent(renderer)
        assert ext.x0 >= fig.bbox.x0 - 1 and ext.y0 >= fig.bbox.y0 - 1 and ext.x1 <= fig.bbox.x1 + 1 \
            and ext.y1 <= fig.bbox.y1 + 1, (t.get_text(), ext, fig.bbox)


def _assert_units(fig) -> None:
    for ax in fig.axes:
        for label in (ax.get_xlabel(), ax.get_ylabel()):
            if label:
                assert UNIT.search(label), label


@pytest.mark.slow
@pytest.mark.parametrize("device", [Device(preset="phantom-1.0"), Device(**RIGID, delay=0.0123),
                                    Device(preset="lhifam")])
def test_bode_and_boundary_texts_inside_the_figure_with_units(device):
    from service.plot_labels import units

    u = units(device)
    bode = bode_figure(loop_frequency_response(device, 0.0, 200), 1.0, device_title(device), u)
    bnd = boundary_figure(stability_boundary(device, None, 10), device_title(device), u)
    for fig in (bode, bnd):
        _assert_inside(fig)
        _assert_units(fig)
    labels = [t.get_text() for t in bode.axes[0].texts]
    assert labels and all(t.endswith(u.stiffness) for t in labels if t[0].isdigit())
    assert bnd.axes[0].get_ylabel().endswith(f"[{u.stiffness}]")
    assert bnd.axes[0].get_xlabel().endswith(f"[{u.damping}]")


def test_rotary_presets_use_rotary_units():
    assert Device(preset="phantom-1.0").rotary and not Device(preset="lhifam").rotary
    assert not Device(mass=1.0, damping=0.0).rotary
    assert path_label("device.cable.stiffness", {"preset": "phantom-1.0"}) == "cable stiffness k_c [N·m/rad]"
    assert path_label("requirements.damping") == "virtual damping B [N·s/m]"
    assert ROTARY.stiffness == "N·m/rad" and TRANSLATIONAL.damping == "N·s/m"


def _grid_rows(xs, ys):
    return [{"device.delay": a, "device.mass": b, "critical_stiffness": 1000.0 + 1e5 * a + b}
            for a in xs for b in ys]


def test_study_heatmap_cells_at_true_values_units_and_value_ticks():
    xs, ys = [0.0, 0.0005, 0.001, 0.003], [1.0, 2.0, 8.0]   # a non-uniform sweep
    fig = study_figure(_grid_rows(xs, ys), "critical_stiffness", "device.delay", "device.mass",
                       "stability study\n" + base_device_title(RIGID, ["device.delay", "device.mass"]))
    ax = fig.axes[0]
    assert ax.get_xlabel() == "delay t_d [ms]" and ax.get_ylabel() == "mass m [kg]"
    assert fig.axes[1].get_ylabel() == "critical stiffness $K_{cr}$ [N/m]"
    mesh = ax.collections[0]
    coords = mesh.get_coordinates()     # (ny+1, nx+1, 2) cell corners
    cx = (coords[0, 1:, 0] + coords[0, :-1, 0]) / 2
    cy = (coords[1:, 0, 1] + coords[:-1, 0, 1]) / 2
    # every swept value lies inside its own cell, in ms on the delay axis
    for v, lo, hi in zip(np.array(xs) * 1e3, coords[0, :-1, 0], coords[0, 1:, 0]):
        assert lo < v < hi
    for v, lo, hi in zip(ys, coords[:-1, 0, 1], coords[1:, 0, 1]):
        assert lo < v < hi
    assert np.all(np.diff(cx) > 0) and np.all(np.diff(cy) > 0)
    assert list(ax.get_xticks()) == pytest.approx(np.array(xs) * 1e3)
    assert list(ax.get_yticks()) == pytest.approx(ys)
    z = mesh.get_array().reshape(len(ys), len(xs))
    assert z[0, 3] == pytest.approx(1000.0 + 1e5 * 0.003 + 1.0)   # the value of (x = 3 ms, m = 1 kg) in its cell
    _assert_inside(fig)
    _assert_units(fig)
    title = ax.get_title()
    assert "t_d swept" in title and "T = 1 ms" in title


def test_study_line_ticks_only_where_values_exist_and_many_values_keep_auto_ticks():
    rows = [{"requirements.damping": b, "critical_stiffness": 100 + b} for b in (0.0, 2.0, 5.0, 20.0)]
    fig = study_figure(rows, "critical_stiffness", "requirements.damping", None, "t")
    ax = fig.axes[0]
    assert list(ax.get_xticks()) == [0.0, 2.0, 5.0, 20.0]
    assert ax.get_xlabel() == "virtual damping B [N·s/m]"
    many = [{"device.mass": m, "critical_stiffness": m} for m in np.linspace(1, 2, 30)]
    fig = study_figure(many, "critical_stiffness", "device.mass", None, "t")
    assert len(fig.axes[0].get_xticks()) < 30
    _assert_inside(fig)


@pytest.mark.slow
def test_study_plot_route_draws_units_and_device(tmp_path):
    from fastapi.testclient import TestClient

    from service.app import create_app
    from service.settings import Settings
    from tests.service.studies_helpers import small_study, wait_finished

    with TestClient(create_app(Settings(database_url=f"sqlite:///{tmp_path / 's.db'}"))) as c:
        sid = c.post("/v1/studies", json=small_study(3)).json()["id"]
        wait_finished(lambda s: c.get(f"/v1/studies/{s}").json(), sid)
        r = c.get(f"/v1/studies/{sid}/plot", params={"y": "critical_stiffness", "x": "device.delay",
                                                     "x2": "requirements.damping", "format": "svg"})
        assert r.status_code == 200, r.text
        drawn = "\n".join(_texts(r.content))
        for text in ("delay t_d [ms]", "virtual damping B [N·s/m]", "critical stiffness $K_{cr}$ [N/m]",
                     "m = 5.4 kg, b = 3.5 N·s/m (rigid), t_d swept, T = 1 ms",
                     f"critical stiffness $K_{{cr}}$ [N/m]: wall-stability study {sid[:8]}"):
            assert text in drawn, drawn
        assert "critical_stiffness" not in drawn and not re.search(r"(^|\n)stability study", drawn)   # no raw names
        # a line plot of a study with a second swept axis: one labelled series per virtual damping
        r = c.get(f"/v1/studies/{sid}/plot", params={"y": "critical_stiffness", "x": "device.delay", "format": "svg"})
        drawn = "\n".join(_texts(r.content))
        assert "B = 0 N·s/m" in drawn and "B = 5 N·s/m" in drawn, drawn
        # a result that is not a number answers 422 naming y (issue 29: 200 with an empty chart)
        results = c.get(f"/v1/studies/{sid}/results", params={"limit": 1}).json()["columns"]
        assert "reason" in results
        bad = c.get(f"/v1/studies/{sid}/plot", params={"y": "reason", "x": "device.delay"})
        assert bad.status_code == 422, bad.text
        assert bad.json()["detail"][0]["loc"] == ["query", "y"] and "'reason'" in bad.json()["detail"][0]["msg"]
        assert "numeric results: " in bad.json()["detail"][0]["msg"]
        assert c.get(f"/v1/studies/{sid}/plot", params={"y": "critical_stiffness", "x": "device.delay"}
                     ).headers["content-type"] == "image/png"
        bad = c.get(f"/v1/studies/{sid}/plot", params={"y": "critical_stiffness", "x": "device.delay",
                                                       "format": "gif"})
        assert bad.status_code == 422 and "format" in bad.text


@pytest.mark.slow
def test_simulation_hardware_robust_identification_figures_inside_with_units():
    from models.simulation.scene import Scene
    from optim.hardware.design import HardwareTarget, design_hardware
    from optim.identification import identify
    from optim.identification.data import TimeSeriesData
    from optim.robust.box import UncertaintyBox
    from optim.robust.stiffness import robust_design_stiffness
    from optim.stiffness import StiffnessRequirements
    from service.jobs import simulate_job
    from service.plot_labels import units
    from service.plots_identification import identification_figure
    from service.plots_robust import hardware_figure, margin_slice, robust_slice_figure
    from service.plots_simulation import simulation_figure

    rot = Device(preset="phantom-1.0", cable=None)
    scene = Scene(**ROUTES["simulation"][0]["scene"] | {"controller": {"stiffness": 100.0}})
    sim = simulation_figure(simulate_job(rot, scene)[0], device=rot)
    assert sim.axes[1].get_ylabel() == "torque [N·m]" and "phantom-1.0 (rigid)" in sim._suptitle.get_text()

    dev = Device(preset="lhifam", cable=None)
    target = HardwareTarget(stiffness=2e5)
    hw = hardware_figure(design_hardware(dev, target, "delay", points=9), target, device_title(dev), units(dev))
    assert hw.axes[-1].get_xlabel() == "delay t_d [ms]"

    box = UncertaintyBox.from_ranges(dev, {k: (v["min"], v["max"]) for k, v in UNC.items()})
    design = robust_design_stiffness(dev, StiffnessRequirements(), box)
    worst = box.to_box(box.to_unit(list(design.worst_case["device"].values())))
    xs, ys, margin = margin_slice(box, design.stiffness, design.damping, worst, "device.mass", "device.delay", 7)
    rb = robust_slice_figure(xs, ys, margin, (worst[0], worst[1]), 6.0, ("device.mass", "device.delay"),
                             device_title(dev))
    assert rb.axes[0].get_ylabel() == "delay t_d [ms]"
    assert rb.axes[0].collections[0].get_coordinates()[:, :, 1].max() <= 2.0 + 1.0  # ms, not s

    d = _ts()
    res = identify(TimeSeriesData(sample_time=0.001, force=np.array(d["force"]), position=np.array(d["position"])),
                   "rigid", None, False, 0.95, None)
    idf = identification_figure(res, 0.001)
    assert "T = 1 ms" in idf._suptitle.get_text() and "m = " in idf._suptitle.get_text()
    for fig in (sim, hw, rb, idf):
        _assert_inside(fig)
        _assert_units(fig)


def test_device_title_says_a_boxed_or_free_parameter_as_its_range():
    """Issue 29: the robust map's title said "t_d = 0 ms" (the nominal device) over a 0.5–1.5 ms delay axis."""
    dev = Device(preset="lhifam", cable=None)
    assert device_title(dev, {"device.delay": (0.0005, 0.0015), "device.damping": (3.0, 4.0)}) == \
        "lhifam (rigid), t_d = 0.5–1.5 ms, T = 1 ms; box: b = 3–4 N·s/m"
    assert device_title(Device(**RIGID), {"device.mass": (4.0, 7.0)}) == \
        "m = 4–7 kg, b = 3.5 N·s/m (rigid), t_d = 0 ms, T = 1 ms"
    assert device_title(dev, free="device.delay") == "lhifam (rigid), t_d free, T = 1 ms"
    assert device_title(dev, free="device.cable.stiffness") == "lhifam (rigid), t_d = 0 ms, T = 1 ms; k_c free"
    assert device_title(dev) == "lhifam (rigid), t_d = 0 ms, T = 1 ms"        # without a box: as before


def _two_axis_rows():
    """K_cr over mass × delay, made up so each delay's series is told by its values."""
    return [{"index": i, "device.mass": m, "device.delay": d, "critical_stiffness": 1000.0 * (1 + k) + m,
             "reason": None} for i, (m, (k, d)) in enumerate((m, kd) for m in (1.0, 4.0, 7.0)
                                                              for kd in enumerate((0.0, 0.0015, 0.003)))]


def test_study_line_plot_with_a_second_swept_axis_draws_one_labelled_series_each():
    """Issue 29: three series were drawn as same-coloured dots with no legend."""
    rows = _two_axis_rows()
    fig = study_figure(rows, "critical_stiffness", "device.mass", None, "t", device=RIGID,
                       paths=["device.mass", "device.delay"])
    ax = fig.axes[0]
    lines = ax.get_lines()
    assert len(lines) == 3
    assert len({ln.get_color() for ln in lines}) == 3 and len({ln.get_linestyle() for ln in lines}) == 3
    assert all(ln.get_linestyle() != "None" for ln in lines)          # lines, not loose dots
    legend = ax.get_legend()
    assert [t.get_text() for t in legend.get_texts()] == ["t_d = 0 ms", "t_d = 1.5 ms", "t_d = 3 ms"]
    for k, ln in enumerate(lines):                                     # each series holds its own delay's points
        assert list(ln.get_xdata()) == [1.0, 4.0, 7.0]
        assert list(ln.get_ydata()) == [1000.0 * (1 + k) + m for m in (1.0, 4.0, 7.0)]
    _assert_inside(fig)
    _assert_units(fig)
    # one swept path: one line, no legend (as before)
    one = study_figure([r for r in rows if r["device.delay"] == 0.0], "critical_stiffness", "device.mass", None,
                       "t", paths=["device.mass", "device.delay"])
    assert len(one.axes[0].get_lines()) == 1 and one.axes[0].get_legend() is None


def test_study_plot_of_a_result_that_is_not_a_number_names_y():
    from optim.errors import InputError

    rows = _two_axis_rows()
    results = ["critical_stiffness", "reason"]
    check_y(rows, "critical_stiffness", results)                       # a number: drawn
    for y, said in (("reason", "holds no number"), ("nonsense", "is not a result")):
        with pytest.raises(InputError) as err:
            check_y(rows, y, results)
        assert err.value.field == "y" and said in err.value.rule, err.value.rule
    text = [dict(r, reason="no crossover") for r in rows]
    with pytest.raises(InputError, match="is text, not a number.*numeric results: critical_stiffness"):
        check_y(text, "reason", results)
    yes_no = [dict(r, stable=True) for r in rows]
    with pytest.raises(InputError, match="is yes/no"):
        check_y(yes_no, "stable", results + ["stable"])


@pytest.mark.slow
def test_simulation_plot_names_the_wall_and_the_blocks_left_out(client):
    """Issue 29: the simulation plot's title lacked K and B, and said nothing of the device blocks the scene
    left out (the LHifAM at 1 ms with K = 3000 N/m looked stable without its delay and cable)."""
    device = {"preset": "lhifam", "delay": 0.001}
    scene = {"experiment": "release", "duration": 0.5, "initial": {"position": 1e-3},
             "controller": {"stiffness": 3000.0, "damping": 0.0}}
    cases = (({}, "stable", "not simulated: delay, cable mode, hand, force-sensor filter"),
             ({"delay": {}, "cable_mode": {}}, "unstable", "not simulated: hand, force-sensor filter"),
             ({"delay": {}, "cable_mode": {}, "human": {}, "force_sensor_filter": {}}, "stable",
              "every block of the device simulated"))
    for effects, state, said in cases:
        r = client.post("/v1/plots/simulation", params={"format": "svg"},
                        json={"device": device, "scene": {**scene, "effects": effects}})
        assert r.status_code == 200, r.text[:300]
        drawn = "\n".join(_texts(r.content))
        assert f"K = 3000 N/m, B = 0 N·s/m: {state} (closed-loop poles)" in drawn, drawn
        assert said in drawn, drawn
    relay = {"experiment": "relay", "duration": 0.5, "relay": {"amplitude": 2.0}, "initial": {"position": 1e-4}}
    r = client.post("/v1/plots/simulation", params={"format": "svg"}, json={"device": RIGID, "scene": relay})
    assert r.status_code == 200 and "relay h = 2 N: " in "\n".join(_texts(r.content))


def test_study_line_plot_with_too_many_series_colours_points_by_the_other_path():
    """A Latin hypercube has a new value of the other path at every point: coloured points and a colour bar
    naming that path, not a legend of 40 entries."""
    from service.studies.plot import MAX_SERIES

    n = 3 * MAX_SERIES
    rows = [{"device.mass": 1.0 + k / 7, "device.delay": 1e-4 * ((k * 7) % n), "critical_stiffness": 1000.0 + k}
            for k in range(n)]
    fig = study_figure(rows, "critical_stiffness", "device.mass", None, "t", device=RIGID,
                       paths=["device.mass", "device.delay"])
    ax, bar = fig.axes
    assert ax.get_legend() is None and not ax.get_lines()
    assert len(ax.collections[0].get_offsets()) == n
    assert bar.get_ylabel() == "delay t_d [ms]"
    assert max(ax.collections[0].get_array()) == pytest.approx(1e-4 * (n - 1) * 1e3)   # coloured in ms
    _assert_inside(fig)
