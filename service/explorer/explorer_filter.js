/* zwidth design explorer: the rendered wall (issue 30).
 *
 * A block beside the boundary: the velocity estimate the damper sees (backward difference, a low-pass of order 1
 * or 2, a moving average) and the virtual mass M.  The boundary K_cr(B) is drawn for today's wall and for the
 * chosen one on one chart (POST /v1/analysis/boundary, with and without `controller`), and the M-width (the
 * stable range of M, `mass_range` of POST /v1/analysis/stability) is read at the chosen boundary's optimum B with
 * half its K_cr (6 dB).  Every number is the API's; the page checks nothing (its 422s are shown as they come).
 * Uses explorer.js's helpers (window.zwidthExplorer: readDevice, api, lineChart, num).
 */
"use strict";
(() => {
  const $ = (id) => document.getElementById(id);
  let timer = null;
  let abort = null;

  function velocityFilter() {
    const kind = $("vf-kind").value;
    if (kind === "low_pass") return { kind, cutoff_hz: Number($("vf-cutoff").value), order: Number($("vf-order").value) };
    if (kind === "moving_average") return { kind, samples: Number($("vf-samples").value) };
    return { kind };
  }

  function controller() {
    const mass = $("vf-mass").value.trim() === "" ? 0 : Number($("vf-mass").value);
    return { mass, velocity_filter: velocityFilter() };
  }

  function syncFields() {
    const kind = $("vf-kind").value;
    $("vf-lowpass").hidden = kind !== "low_pass";
    $("vf-average").hidden = kind !== "moving_average";
  }

  function schedule() {
    clearTimeout(timer);
    timer = setTimeout(refresh, 400);
  }

  function messages(err) {
    const detail = err && err.payload && err.payload.detail;
    if (Array.isArray(detail)) return detail.map((e) => `${(e.loc || []).slice(1).join(".")}: ${e.msg}`).join("; ");
    return err && err.message ? err.message : String(err);
  }

  async function refresh() {
    const X = window.zwidthExplorer;
    if (!X) return;
    if (abort) abort.abort();
    const ctl = new AbortController();
    abort = ctl;
    const device = X.readDevice();
    const ctrl = controller();
    $("filter-error").textContent = "";
    $("filter-facts").classList.add("busy");
    try {
      const [plain, chosen] = await Promise.all([
        X.api("/v1/analysis/boundary", { method: "POST", body: { device, points: 60 }, signal: ctl.signal }),
        X.api("/v1/analysis/boundary", { method: "POST", body: { device, points: 60, controller: ctrl },
                                         signal: ctl.signal }),
      ]);
      const o = chosen.optimum;
      $("filter-bmax").textContent = chosen.max_stable_damping === null ? "—" : `${X.num(chosen.max_stable_damping)} N·s/m`;
      $("filter-optimum").textContent = `K_cr ${X.num(o.critical_stiffness)} N/m at B ${X.num(o.damping)} N·s/m`;
      X.lineChart($("filter-chart"), {
        series: [
          { label: "with the chosen filter and M", points: chosen.points.map((p) => [p.damping, p.critical_stiffness]) },
          { label: "today's wall (backward difference, M = 0)", points: plain.points.map((p) => [p.damping, p.critical_stiffness]) },
        ],
        xLabel: "virtual damping B [N·s/m]", yLabel: "critical stiffness K_cr [N/m]",
        vlines: chosen.max_stable_damping ? [{ x: chosen.max_stable_damping, label: "B_max (filter)" }] : [],
        hover: ([b, k]) => { $("filter-hover").textContent = `with the filter: K_cr(${X.num(b, 4)} N·s/m) = ${X.num(k)} N/m`; },
      });
      $("filter-mwidth").textContent = "—";
      if (o.critical_stiffness > 0 && Number.isFinite(o.critical_stiffness)) {
        const k = o.critical_stiffness / 2;
        const st = await X.api("/v1/analysis/stability", {
          method: "POST", signal: ctl.signal,
          body: { device, controller: { stiffness: k, damping: o.damping, ...ctrl } } });
        const r = st.mass_range;
        $("filter-mwidth").textContent = r ? `[${X.num(r.min, 4)}, ${X.num(r.max, 4)}] kg (K ${X.num(k)} N/m, B ${X.num(o.damping)} N·s/m)`
          : "— (the wall is unstable)";
      }
    } catch (err) {
      if (err.name === "AbortError") return;
      $("filter-error").textContent = messages(err);
    } finally {
      if (abort === ctl) $("filter-facts").classList.remove("busy");
    }
  }

  function start() {
    syncFields();
    $("filter-block").addEventListener("input", () => { syncFields(); schedule(); });
    $("filter-block").addEventListener("change", () => { syncFields(); schedule(); });
    $("device-form").addEventListener("input", schedule);
    $("preset").addEventListener("change", schedule);
    // explorer.js fills the device once the presets are read: draw then
    const ready = new MutationObserver(() => { if (document.body.dataset.ready === "true") { ready.disconnect(); schedule(); } });
    ready.observe(document.body, { attributes: true, attributeFilter: ["data-ready"] });
    if (document.body.dataset.ready === "true") schedule();
  }

  document.addEventListener("DOMContentLoaded", start);
})();
