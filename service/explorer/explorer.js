/* zwidth design explorer.
 *
 * Every number on this page comes from the service's /v1 API, the same calls every other client makes: the page
 * validates nothing itself (the API's 422 messages are shown next to the field they name) and computes nothing
 * but axis ticks.  Curves with hover (boundary, Pareto, hardware trade-off) are drawn here from the API's numbers;
 * the simulation, identification and study figures are the service's own SVG plots.
 */
"use strict";
(() => {
  const $ = (id) => document.getElementById(id);
  const TOKEN_KEY = "zwidth.token";
  const SVG_NS = "http://www.w3.org/2000/svg";

  // ------------------------------------------------------------------ the API
  class ApiError extends Error {
    constructor(status, payload) {
      super(`HTTP ${status}`);
      this.status = status;
      this.payload = payload;
    }
  }

  let tokenPrompt = null;   // one dialog for every request that met a 401

  function askToken(message) {
    if (tokenPrompt) return tokenPrompt;
    tokenPrompt = new Promise((resolve) => {
      const dialog = $("token-dialog");
      $("token-error").textContent = message || "";
      $("token-input").value = "";
      $("token-form").onsubmit = (ev) => {
        ev.preventDefault();
        const value = $("token-input").value.trim();
        if (!value) { $("token-error").textContent = "Enter the token the server was started with."; return; }
        sessionStorage.setItem(TOKEN_KEY, value);
        dialog.close();
        $("token-button").hidden = false;
        tokenPrompt = null;
        resolve();
      };
      if (!dialog.open) dialog.showModal();
      $("token-input").focus();
    });
    return tokenPrompt;
  }

  async function api(path, { method = "GET", body, signal, raw = false } = {}) {
    for (;;) {
      const headers = {};
      const token = sessionStorage.getItem(TOKEN_KEY);
      if (token) headers.Authorization = `Bearer ${token}`;
      if (body !== undefined) headers["Content-Type"] = "application/json";
      const r = await fetch(path, { method, headers, signal,
                                    body: body === undefined ? undefined : JSON.stringify(body) });
      if (r.status === 401) {
        if (token) sessionStorage.removeItem(TOKEN_KEY);
        await askToken(token ? "The server refused that token; try again." : "");
        continue;
      }
      if (!r.ok) {
        let payload;
        try { payload = await r.json(); } catch { payload = { detail: r.statusText || `HTTP ${r.status}` }; }
        throw new ApiError(r.status, payload);
      }
      if (raw) return r;
      return r.status === 204 ? null : r.json();
    }
  }

  /** The API's error body as [{path, msg}] (path without the leading "body"/"query"). */
  function errorsOf(err) {
    if (!(err instanceof ApiError)) return [{ path: [], msg: String(err && err.message || err) }];
    const detail = err.payload && err.payload.detail;
    if (Array.isArray(detail)) {
      return detail.map((d) => ({ path: (d.loc || []).filter((p, i) => !(i === 0 && (p === "body" || p === "query"))),
                                  msg: typeof d.msg === "string" ? d.msg : JSON.stringify(d.msg ?? d) }));
    }
    const msg = typeof detail === "string" ? detail : (err.payload && (err.payload.message || err.payload.error))
      || `HTTP ${err.status}`;
    const field = err.payload && err.payload.field;
    return [{ path: field ? String(field).split(".") : [], msg: `${msg}${err.status === 503 ? " (server busy)" : ""}` }];
  }

  /** Errors in one line of words: "field: message; field: message" (the field the API named, when it did). */
  const says = (items) => items.map((e) => (e.path.length ? `${e.path.join(".")}: ${e.msg}` : e.msg)).join("; ");

  // ------------------------------------------------------------------ formatting
  function num(v, digits = 6) {
    if (v === null || v === undefined) return "—";
    if (typeof v !== "number") return String(v);
    if (v === 0) return "0";
    const a = Math.abs(v);
    if (a >= 1e-3 && a < 1e7) return String(Number(v.toPrecision(digits)));
    return v.toExponential(digits - 1).replace(/\.?0+e/, "e");
  }
  const withUnit = (v, unit, digits) => (v === null || v === undefined ? "—" : `${num(v, digits)} ${unit}`);
  const escapeText = (s) => String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" }[c]));

  const CONSTRAINT_WORDS = {
    min_gain_margin_db: "the gain margin", passivity: "passivity (with the delay)", max_damping: "the damping limit B_max",
    max_stiffness: "the stiffness limit", max_force: "actuator saturation", max_force_noise: "force noise from the encoder",
    stability: "stability", stiffness: "the stiffness target", force_gain: "the force-gain target",
    apparent_mass: "the apparent-mass target",
  };
  const words = (names) => (names && names.length ? names.map((n) => CONSTRAINT_WORDS[n] || n).join(", ") : "none");

  function statusBadge(status) {
    const good = ["optimal", "identified", "stable", "confirmed", "done", "feasible"];
    const bad = ["infeasible", "failed", "unsafe", "unstable", "contradicted", "cancelled"];
    const cls = good.includes(status) ? "good" : bad.includes(status) ? "bad" : "unsure";
    return `<span class="status ${cls}" data-status="${escapeText(status)}">${escapeText(status)}</span>`;
  }

  function table(rows) {
    return `<table><tbody>${rows.filter(Boolean).map(([k, v, id]) =>
      `<tr><th scope="row">${k}</th><td${id ? ` id="${id}"` : ""}>${v}</td></tr>`).join("")}</tbody></table>`;
  }

  function verificationRows(v) {
    if (!v) return [];
    const rows = [["verification", statusBadge(v.verdict || v.status || "unknown")]];
    for (const [k, val] of Object.entries(v)) {
      if (k === "verdict" || k === "status" || (val !== null && typeof val === "object")) continue;
      rows.push([`verification ${escapeText(k)}`, escapeText(typeof val === "number" ? num(val) : val)]);
    }
    return rows;
  }

  /** The API's errors as the page says them: the field the API named (dotted), then its message. */
  function showError(container, items) {
    container.innerHTML = `<p class="form-error" role="alert">${items.map((e) =>
      `${e.path.length ? `<code>${escapeText(e.path.join("."))}</code>: ` : ""}${escapeText(e.msg)}`).join("<br>")}</p>`;
  }

  // ------------------------------------------------------------------ the device form
  // API path → [input id, factor from the input's unit to SI]
  const DEVICE_FIELDS = {
    mass: ["mass", 1], damping: ["damping", 1], sample_time: ["sample_time_ms", 1e-3], delay: ["delay_ms", 1e-3],
    "cable.motor_mass": ["cable_motor_mass", 1], "cable.motor_damping": ["cable_motor_damping", 1],
    "cable.body_mass": ["cable_body_mass", 1], "cable.body_damping": ["cable_body_damping", 1],
    "cable.stiffness": ["cable_stiffness", 1], "cable.damping": ["cable_damping", 1],
    "human.mass": ["human_mass", 1], "human.damping": ["human_damping", 1], "human.stiffness": ["human_stiffness", 1],
    "force_sensor.time_constant": ["sensor_tc_ms", 1e-3],
    encoder_resolution: ["encoder_um", 1e-6], coulomb_friction: ["coulomb_friction", 1], travel: ["travel_mm", 1e-3],
  };
  let presets = {};

  const isCable = () => $("model-cable").checked;

  function readValue(id, factor) {
    const el = $(id);
    if (el.value === "") return undefined;
    const v = Number(el.value);
    return Number.isFinite(v) ? v * factor : el.value;    // a non-number goes to the API, which names the rule
  }

  /** The device object of the form, in SI units, exactly as the API takes it. */
  function readDevice() {
    const device = {};
    const blocks = { cable: isCable(), human: $("human_on").checked, force_sensor: $("sensor_on").checked };
    for (const [path, [id, factor]] of Object.entries(DEVICE_FIELDS)) {
      const parts = path.split(".");
      if (parts.length === 2 && !blocks[parts[0]]) continue;
      if (parts.length === 1 && isCable() && (path === "mass" || path === "damping")) continue;
      const v = readValue(id, factor);
      if (v === undefined) continue;
      if (parts.length === 1) device[path] = v;
      else (device[parts[0]] = device[parts[0]] || {})[parts[1]] = v;
    }
    return device;
  }

  function fillDevice(dev) {
    $("model-cable").checked = Boolean(dev.cable);
    $("model-rigid").checked = !dev.cable;
    $("human_on").checked = Boolean(dev.human);
    $("sensor_on").checked = Boolean(dev.force_sensor);
    for (const [path, [id, factor]] of Object.entries(DEVICE_FIELDS)) {
      const parts = path.split(".");
      const v = parts.length === 1 ? dev[path] : dev[parts[0]] && dev[parts[0]][parts[1]];
      if (v !== undefined && v !== null) $(id).value = Number((v / factor).toPrecision(12));
      else if (parts.length === 1) $(id).value = "";
    }
    syncBlocks();
  }

  function syncBlocks() {
    $("rigid-fields").hidden = isCable();
    $("cable-fields").hidden = !isCable();
    $("human-fields").hidden = !$("human_on").checked;
    $("sensor-fields").hidden = !$("sensor_on").checked;
  }

  function clearFieldErrors() {
    for (const el of document.querySelectorAll(".device .field-error")) el.textContent = "";
    for (const el of document.querySelectorAll(".device input[aria-invalid]")) el.removeAttribute("aria-invalid");
    $("device-error").textContent = "";
  }

  /** Puts the API's messages about device fields next to those fields; returns the others. */
  function showDeviceErrors(err) {
    const rest = [];
    for (const e of errorsOf(err)) {
      const path = e.path[0] === "device" ? e.path.slice(1).join(".") : null;
      const field = path !== null && DEVICE_FIELDS[path];
      if (field) {
        $(`err-${field[0]}`).textContent = e.msg;
        $(field[0]).setAttribute("aria-invalid", "true");
      } else if (path !== null) {
        $("device-error").textContent = `${path || "device"}: ${e.msg}`;
      } else {
        rest.push(e);
      }
    }
    return rest;
  }

  // ------------------------------------------------------------------ charts (drawn from the API's numbers)
  function ticks(lo, hi, n = 6) {
    if (!(hi > lo)) { hi = lo + 1; }
    const step0 = (hi - lo) / n;
    const mag = 10 ** Math.floor(Math.log10(step0));
    const step = [1, 2, 5, 10].map((m) => m * mag).find((s) => s >= step0);
    const out = [];
    for (let t = Math.ceil(lo / step) * step; t <= hi + step * 1e-9; t += step) out.push(Number(t.toPrecision(12)));
    return out;
  }

  function el(name, attrs = {}, text) {
    const node = document.createElementNS(SVG_NS, name);
    for (const [k, v] of Object.entries(attrs)) node.setAttribute(k, v);
    if (text !== undefined) node.textContent = text;
    return node;
  }

  /** A line chart: series [{label, points: [[x, y]...]}], optional vertical lines, markers and a hover readout. */
  function lineChart(container, { series, xLabel, yLabel, vlines = [], markers = [], hover }) {
    container.textContent = "";
    const W = 760, H = 340, L = 78, R = 18, T = 14, B = 46;
    const pts = series.flatMap((s) => s.points).filter(([x, y]) => Number.isFinite(x) && Number.isFinite(y));
    if (!pts.length) { container.textContent = "nothing to draw"; return; }
    const xs = pts.map((p) => p[0]).concat(vlines.map((v) => v.x).filter(Number.isFinite));
    // The y-range follows the first (main) series: a straight-line estimate must not flatten the exact curve.
    const main0 = series[0].points.filter(([x, y]) => Number.isFinite(x) && Number.isFinite(y));
    const ys = (main0.length ? main0 : pts).map((p) => p[1]);
    const [x0, x1] = [Math.min(...xs), Math.max(...xs)];
    const [y0, y1] = [Math.min(0, ...ys), Math.max(...ys) * 1.15 || 1];
    const sx = (x) => L + ((x - x0) / ((x1 - x0) || 1)) * (W - L - R);
    const sy = (y) => H - B - ((y - y0) / ((y1 - y0) || 1)) * (H - T - B);
    const svg = el("svg", { viewBox: `0 0 ${W} ${H}`, "aria-hidden": "true" });
    const clipId = `clip-${container.id}`;
    const clip = el("clipPath", { id: clipId });
    clip.append(el("rect", { x: L, y: T, width: W - L - R, height: H - T - B }));
    svg.append(clip);
    for (const t of ticks(x0, x1)) {
      svg.append(el("line", { x1: sx(t), x2: sx(t), y1: T, y2: H - B, class: "grid" }));
      svg.append(el("text", { x: sx(t), y: H - B + 16, "text-anchor": "middle" }, num(t, 4)));
    }
    for (const t of ticks(y0, y1)) {
      svg.append(el("line", { x1: L, x2: W - R, y1: sy(t), y2: sy(t), class: "grid" }));
      svg.append(el("text", { x: L - 6, y: sy(t) + 4, "text-anchor": "end" }, num(t, 4)));
    }
    svg.append(el("line", { x1: L, x2: W - R, y1: H - B, y2: H - B, class: "axis" }));
    svg.append(el("line", { x1: L, x2: L, y1: T, y2: H - B, class: "axis" }));
    svg.append(el("text", { x: (L + W - R) / 2, y: H - 8, "text-anchor": "middle" }, xLabel));
    svg.append(el("text", { x: 14, y: (T + H - B) / 2, "text-anchor": "middle",
                            transform: `rotate(-90 14 ${(T + H - B) / 2})` }, yLabel));
    series.forEach((s, i) => {
      let d = "";
      let pen = false;
      for (const [x, y] of s.points) {
        if (!Number.isFinite(x) || !Number.isFinite(y)) { pen = false; continue; }
        d += `${pen ? "L" : "M"}${sx(x).toFixed(1)},${sy(y).toFixed(1)}`;
        pen = true;
      }
      svg.append(el("path", { d, class: `series-${i % 2}`, "clip-path": `url(#${clipId})` }));
      svg.append(el("text", { x: L + 10, y: T + 14 + 14 * i, "text-anchor": "start", class: `legend-${i}` },
                    `${i % 2 ? "- - " : "— "}${s.label}`));
    });
    for (const v of vlines) {
      if (!Number.isFinite(v.x)) continue;
      svg.append(el("line", { x1: sx(v.x), x2: sx(v.x), y1: T, y2: H - B, class: "vline" }));
      svg.append(el("text", { x: sx(v.x) - 4, y: H - B - 6, "text-anchor": "end" }, v.label));
    }
    for (const m of markers) {
      const c = el("circle", { cx: sx(m.x), cy: sy(m.y), r: 6, class: "marker", tabindex: "0", role: "button",
                               "aria-label": m.label });
      c.append(el("title", {}, m.label));
      if (m.onClick) {
        c.addEventListener("click", m.onClick);
        c.addEventListener("keydown", (ev) => { if (ev.key === "Enter" || ev.key === " ") m.onClick(); });
      }
      svg.append(c);
    }
    if (hover) {
      const dot = el("circle", { r: 4, class: "hover", visibility: "hidden" });
      svg.append(dot);
      const main = series[0].points.filter(([x, y]) => Number.isFinite(x) && Number.isFinite(y));
      svg.addEventListener("mousemove", (ev) => {
        const box = svg.getBoundingClientRect();
        const x = x0 + ((ev.clientX - box.left) * (W / box.width) - L) / (W - L - R) * (x1 - x0);
        let best = main[0];
        for (const p of main) if (Math.abs(p[0] - x) < Math.abs(best[0] - x)) best = p;
        dot.setAttribute("cx", sx(best[0]));
        dot.setAttribute("cy", sy(best[1]));
        dot.setAttribute("visibility", "visible");
        hover(best);
      });
    }
    container.append(svg);
  }

  // ------------------------------------------------------------------ boundary panel
  let boundaryAbort = null;
  let boundaryTimer = null;

  function scheduleBoundary() {
    clearTimeout(boundaryTimer);
    boundaryTimer = setTimeout(refreshBoundary, 350);     // debounced: one redraw per pause in typing
  }

  async function refreshBoundary() {
    if (boundaryAbort) boundaryAbort.abort();
    const ctl = new AbortController();
    boundaryAbort = ctl;
    const device = readDevice();
    $("analysis-facts").classList.add("busy");
    try {
      const [st, bd] = await Promise.all([
        api("/v1/analysis/stability", { method: "POST", body: { device }, signal: ctl.signal }),
        api("/v1/analysis/boundary", { method: "POST", body: { device, points: 60 }, signal: ctl.signal }),
      ]);
      clearFieldErrors();
      $("kcr").textContent = withUnit(st.critical_stiffness, "N/m");
      $("kcr-rigid").textContent = withUnit(st.rigid_critical_stiffness ?? (isCable() ? null : st.critical_stiffness), "N/m");
      $("kcr-omega").textContent = withUnit(st.crossover_frequency, "rad/s");
      $("kcr-linear").textContent = withUnit(st.linear_estimate, "N/m");
      $("mode-matters").textContent = st.mode_matters === null || st.mode_matters === undefined ? "—"
        : st.mode_matters ? "yes (> 5 % from the rigid model)" : "no";
      $("bmax").textContent = withUnit(bd.max_stable_damping, "N·s/m");
      $("optimum").textContent = `K_cr ${withUnit(bd.optimum.critical_stiffness, "N/m")} at B ${withUnit(bd.optimum.damping, "N·s/m")}`;
      $("boundary-elapsed").textContent = `${num(st.elapsed_ms, 3)} ms + ${num(bd.elapsed_ms, 3)} ms`;
      drawBoundary(bd);
      if (window.zwidthQuant) window.zwidthQuant.boundary($("boundary-chart"), bd, device, api);   // explorer_quant.js
    } catch (err) {
      if (err.name === "AbortError") return;
      clearFieldErrors();
      const rest = showDeviceErrors(err);
      if (rest.length) $("device-error").textContent = says(rest);
    } finally {
      if (boundaryAbort === ctl) $("analysis-facts").classList.remove("busy");
    }
  }

  function drawBoundary(bd) {
    lineChart($("boundary-chart"), {
      series: [
        { label: "K_cr(B), exact", points: bd.points.map((p) => [p.damping, p.critical_stiffness]) },
        { label: "linear estimate (eq. 10)", points: bd.points.map((p) => [p.damping, p.linear_estimate]) },
      ],
      xLabel: "virtual damping B [N·s/m]", yLabel: "critical stiffness K_cr [N/m]",
      vlines: bd.max_stable_damping ? [{ x: bd.max_stable_damping, label: "B_max" }] : [],
      markers: [{ x: bd.optimum.damping, y: bd.optimum.critical_stiffness,
                  label: `optimum: K_cr ${num(bd.optimum.critical_stiffness)} N/m at B ${num(bd.optimum.damping)} N·s/m`,
                  onClick: () => { $("st-max-damping").value = ""; selectTab("tab-stiffness"); } }],
      hover: ([b, k]) => { $("boundary-hover").textContent = `K_cr(${num(b, 4)} N·s/m) = ${num(k)} N/m`; },
    });
  }

  // ------------------------------------------------------------------ design panels
  function optional(id) {
    const v = $(id).value;
    return v === "" ? undefined : Number(v);
  }

  async function runPanel(button, output, call) {
    button.disabled = true;
    output.innerHTML = "<p class=\"busy\">computing</p>";
    try {
      await call();
    } catch (err) {
      // Every error the API answered is shown with its field and message: those about a device field beside
      // that field too, the others (a requirement, the box, the scene) here.
      clearFieldErrors();
      const all = errorsOf(err);
      const rest = showDeviceErrors(err);
      showError(output, rest.length ? rest : all);
      if (rest.length < all.length) {
        output.insertAdjacentHTML("beforeend", "<p>See the device form for the field the server named.</p>");
      }
    } finally {
      button.disabled = false;
    }
  }

  function stiffnessRows(r, prefix = "stiffness") {
    return [
      ["status", statusBadge(r.status), `${prefix}-status`],
      ["wall stiffness K", withUnit(r.stiffness, "N/m"), `${prefix}-K`],
      ["virtual damping B", withUnit(r.damping, "N·s/m"), `${prefix}-B`],
      ["K_cr at this B", withUnit(r.critical_stiffness, "N/m")],
      ["gain margin", withUnit(r.gain_margin_db, "dB", 4)],
      ["crossover ω", withUnit(r.crossover_frequency, "rad/s")],
      ["limited by", escapeText(words(r.active_constraints)), `${prefix}-limit`],
      r.reason ? ["reason", escapeText(r.reason)] : null,
      r.passivity_note ? ["passivity", escapeText(r.passivity_note)] : null,
      ...(r.sensitivities || []).slice(0, 4).map((s) => ["sensitivity", escapeText(s.statement)]),
      ["elapsed", withUnit(r.elapsed_ms, "ms", 4), `${prefix}-elapsed`],
      ...verificationRows(r.verification),
    ];
  }

  async function designStiffness(ev) {
    ev.preventDefault();
    await runPanel($("st-run"), $("stiffness-result"), async () => {
      const requirements = { min_gain_margin_db: Number($("st-margin").value), passivity: $("st-passivity").checked };
      if (optional("st-max-damping") !== undefined) requirements.max_damping = optional("st-max-damping");
      if (optional("st-max-stiffness") !== undefined) requirements.max_stiffness = optional("st-max-stiffness");
      const body = { device: readDevice(), requirements };
      if ($("st-verify").checked) body.verify = true;
      const r = await api("/v1/design/stiffness", { method: "POST", body });
      $("stiffness-result").innerHTML = table(stiffnessRows(r));
    });
  }

  async function designInertia(ev) {
    ev.preventDefault();
    await runPanel($("in-run"), $("inertia-result"), async () => {
      const requirements = { min_gain_margin_db: Number($("in-margin").value), filter_order: Number($("in-order").value) };
      if (optional("in-target") !== undefined) requirements.target_apparent_mass = optional("in-target");
      const body = { device: readDevice(), requirements };
      if ($("in-verify").checked) body.verify = true;
      const r = await api("/v1/design/inertia", { method: "POST", body });
      $("inertia-result").innerHTML = table([
        ["status", statusBadge(r.status), "inertia-status"],
        ["force gain K_f", num(r.force_gain), "inertia-Kf"],
        ["filter cutoff", withUnit(r.filter_cutoff_hz, "Hz"), "inertia-cutoff"],
        ["apparent mass", withUnit(r.apparent_mass, "kg"), "inertia-mass"],
        ["K_f,cr at this cutoff", num(r.critical_force_gain)],
        ["gain margin", withUnit(r.gain_margin_db, "dB", 4)],
        ["cutoff band", r.cutoff_band_hz ? `${num(r.cutoff_band_hz[0])} – ${num(r.cutoff_band_hz[1])} Hz` : "—"],
        r.reason ? ["reason", escapeText(r.reason)] : null,
        ...(r.notes || []).map((n) => ["note", escapeText(n)]),
        ["elapsed", withUnit(r.elapsed_ms, "ms", 4)],
        ...verificationRows(r.verification),
      ]);
      const pareto = (r.pareto || []).map((p) => [p.cutoff_hz ?? p.filter_cutoff_hz, p.force_gain ?? p.critical_force_gain]);
      if (pareto.length) {
        lineChart($("pareto-chart"), {
          series: [{ label: "best K_f for each cutoff (exact)", points: pareto }],
          xLabel: "filter cutoff [Hz]", yLabel: "force gain K_f [–]",
          markers: r.filter_cutoff_hz ? [{ x: r.filter_cutoff_hz, y: r.force_gain, label: "the design" }] : [],
          hover: ([f, k]) => { $("inertia-result").dataset.hover = `${f} Hz: ${k}`; },
        });
      } else {
        $("pareto-chart").textContent = "";
      }
    });
  }

  // The Robust tab's default box follows the model: a rigid device's damping b, or a cable device's body
  // damping b_d (the API refuses device.damping on a cable device), each ±1/7 around the form's value, and the
  // loop delay 0.5–1.5 ms.  A box the user edited is left as it is.
  let robustDefault = null;

  function defaultBox() {
    const dev = readDevice();
    const span = (v) => ({ min: Number((v * 6 / 7).toPrecision(3)), max: Number((v * 8 / 7).toPrecision(3)) });
    const box = { "device.delay": { min: 0.0005, max: 0.0015 } };
    const b = isCable() ? dev.cable && dev.cable.body_damping : dev.damping;
    if (typeof b === "number" && b > 0) box[isCable() ? "device.cable.body_damping" : "device.damping"] = span(b);
    return box;
  }

  function syncRobustBox() {
    const el = $("rb-box");
    if (robustDefault !== null && el.value !== robustDefault) return;
    robustDefault = `{${Object.entries(defaultBox()).map(([k, v]) => JSON.stringify(k) + ": " + JSON.stringify(v)
      .replace(/,/g, ", ").replace(/:/g, ": ")).join(",\n ")}}`;
    el.value = robustDefault;
  }

  async function designRobust(ev) {
    ev.preventDefault();
    await runPanel($("rb-run"), $("robust-result"), async () => {
      let box;
      try { box = JSON.parse($("rb-box").value); } catch (e) {
        throw new ApiError(422, { detail: [{ loc: ["body", "requirements", "uncertainty"], msg: `not JSON: ${e.message}` }] });
      }
      const body = { device: readDevice(), requirements: { min_gain_margin_db: Number($("rb-margin").value),
                                                             passivity: $("rb-passivity").checked, uncertainty: box } };
      if ($("rb-verify").checked) body.verify = true;
      const r = await api("/v1/design/stiffness", { method: "POST", body });
      const wd = r.worst_case && (r.worst_case.device || r.worst_case);
      const worst = wd ? Object.entries(wd).filter(([, v]) => typeof v !== "object")
        .map(([k, v]) => `${escapeText(k)} = ${num(v)}`).join(", ") : "—";
      $("robust-result").innerHTML = table([...stiffnessRows(r, "robust"), ["worst device", worst],
        ["nominal margin", withUnit(r.nominal_gain_margin_db, "dB", 4)]]);
    });
  }

  const FREE_UNITS = { delay: "s", sample_time: "s", damping: "N·s/m", mass: "kg", "cable.stiffness": "N/m" };

  async function designHardware(ev) {
    ev.preventDefault();
    await runPanel($("hw-run"), $("hardware-result"), async () => {
      const body = { device: readDevice(), free: $("hw-free").value,
                     target: { stiffness: Number($("hw-stiffness").value), min_gain_margin_db: Number($("hw-margin").value) } };
      const r = await api("/v1/design/hardware", { method: "POST", body });
      $("hardware-result").innerHTML = table([
        ["status", statusBadge(r.status), "hardware-status"],
        [`loosest ${escapeText(r.free)}`, withUnit(r.value, FREE_UNITS[r.free] || "(SI)"), "hardware-value"],
        ["direction", escapeText(r.direction)],
        ["feasible set", (r.intervals || []).map(([a, b]) => `[${num(a)}, ${num(b)}]`).join(" ∪ ") || "—"],
        ["limiting effect", escapeText(r.limiting_effect || "—")],
        r.reason ? ["reason", escapeText(r.reason)] : null,
        r.note ? ["note", escapeText(r.note)] : null,
        ["elapsed", withUnit(r.elapsed_ms, "ms", 4)],
      ]);
      if (window.zwidthQuant) window.zwidthQuant.hardware($("hardware-result"), r);            // explorer_quant.js
      const curve = (r.curve || []).map((p) => [p.value, p.achievable_stiffness]);
      if (curve.some(([, k]) => Number.isFinite(k))) {
        lineChart($("hardware-chart"), {
          series: [{ label: "achievable stiffness", points: curve }],
          xLabel: `${r.free} [${FREE_UNITS[r.free] || "SI"}]`, yLabel: "achievable stiffness [N/m]",
          vlines: r.value !== null ? [{ x: r.value, label: "answer" }] : [],
        });
      } else {
        $("hardware-chart").textContent = "";
      }
    });
  }

  // ------------------------------------------------------------------ simulate
  async function showImage(img, response) {
    const blob = await response.blob();
    if (img.dataset.url) URL.revokeObjectURL(img.dataset.url);
    img.dataset.url = URL.createObjectURL(blob);
    img.src = img.dataset.url;
    img.hidden = false;
  }

  // The scene names the device's effects ticked in the Simulate tab (/v1/simulate simulates only what a scene
  // names): the delay, the cable mode and the force-sensor filter by default, the hand when ticked (a release
  // lets go of the handle, and the wall's analysis, K_cr, has no hand).  A box is disabled when the device has
  // no such block; whatever the device has and the scene leaves out is said beside the answer and on the figure.
  const EFFECT_WORDS = { delay: "the loop delay", cable: "the cable mode", human: "the hand", force_sensor: "the force-sensor filter" };
  const effectBoxes = () => [...document.querySelectorAll("#sim-effects input[data-effect]")];
  const deviceHas = (block, dev) => (block === "delay" ? typeof dev.delay === "number" && dev.delay > 0 : Boolean(dev[block]));

  function syncEffects() {
    const dev = readDevice();
    const out = [];
    for (const box of effectBoxes()) {
      const has = deviceHas(box.dataset.block, dev);
      box.disabled = !has;
      box.closest("label").title = has ? "" : "the device in the form has none";
      if (has && !box.checked) out.push(EFFECT_WORDS[box.dataset.block]);
    }
    $("sim-effects-note").textContent = out.length ? `Left out (unticked): ${out.join(", ")}.` : "";
  }

  function sceneEffects(dev) {
    const effects = {};
    for (const box of effectBoxes()) {
      if (box.checked && deviceHas(box.dataset.block, dev)) effects[box.dataset.effect] = {};
    }
    return effects;
  }

  /** Why the scene's verdict and the wall's analysis (delay and cable, no hand) may differ, in words. */
  function sceneVersusAnalysis(device, effects) {
    const diff = [];
    if (deviceHas("delay", device) && !effects.delay) diff.push("leaves out the delay");
    if (device.cable && !effects.cable_mode) diff.push("leaves out the cable mode");
    if (effects.human) diff.push("adds the hand holding the handle");
    return diff;
  }

  async function simulate(ev) {
    ev.preventDefault();
    await runPanel($("sim-run"), $("simulate-result"), async () => {
      const experiment = $("sim-experiment").value;
      const device = readDevice();
      const scene = { experiment, duration: Number($("sim-duration").value),
                      initial: { position: Number($("sim-position").value) * 1e-3 }, output_points: 800,
                      effects: sceneEffects(device) };
      if (experiment === "release") {
        scene.controller = { stiffness: Number($("sim-stiffness").value), damping: Number($("sim-damping").value) };
      } else {
        scene.relay = { amplitude: 1.0 };
      }
      const body = { device, scene };
      const [r, wall] = await Promise.all([
        api("/v1/simulate", { method: "POST", body }),
        scene.controller ? api("/v1/analysis/stability", { method: "POST", body: { device, controller: scene.controller } })
          .catch(() => null) : null,
      ]);
      const v = r.verdict || {};
      const leftOut = r.not_simulated || [];
      const rows = [
        ["verdict", statusBadge(v.state || "undetermined"), "simulate-verdict"],
        ["reason", escapeText(v.reason || "—")],
        ["decided by", escapeText(v.decided_by || "—")],
        ["oscillation ω", withUnit(v.frequency, "rad/s")],
        ["amplitude at the end", withUnit(v.amplitude, "m")],
        ["effects simulated", escapeText((r.effects_simulated || []).join(", ") || "none"), "simulate-effects"],
        ["not simulated", escapeText(leftOut.join("; ") || "none (every block of the device)"), "simulate-left-out"],
      ];
      if (wall) {
        const state = wall.stable === true ? "stable" : wall.stable === false ? "unstable" : "undetermined";
        const diff = sceneVersusAnalysis(device, scene.effects);
        rows.push(["the wall's analysis (delay and cable, no hand)",
                   `${statusBadge(state)} K<sub>cr</sub>(B) = ${escapeText(withUnit(wall.critical_stiffness, "N/m"))}, `
                   + `gain margin ${escapeText(withUnit(wall.gain_margin_db, "dB", 4))}`
                   + (diff.length && state !== v.state ? ` — differs from the simulation: the scene ${escapeText(diff.join(" and "))}` : ""),
                   "simulate-analysis"]);
      }
      rows.push(
        ["energy generated", withUnit(r.energy_generated, "J")],
        ["elapsed", withUnit(r.elapsed_ms, "ms", 4)]);
      for (const [k, val] of Object.entries(v)) {
        if (val && typeof val === "object" && !Array.isArray(val)) {
          rows.push([escapeText(k), escapeText(Object.entries(val).filter(([, x]) => typeof x !== "object")
            .map(([a, b]) => `${a}: ${typeof b === "number" ? num(b) : b}`).join(", "))]);
        }
      }
      if (r.relay && r.relay.cycles) rows.push(["relay cycles", String(r.relay.cycles.length)]);
      const warn = leftOut.length ? `<p class="left-out" id="simulate-warning" role="note">Not simulated: ${
        escapeText(leftOut.map((n) => n.split(":")[0]).map((b) => EFFECT_WORDS[b] || b).join(", "))
      }. The verdict is for the device without ${leftOut.length > 1 ? "them" : "it"}.</p>` : "";
      $("simulate-result").innerHTML = warn + table(rows);
      const plot = await api("/v1/plots/simulation?format=svg", { method: "POST", body, raw: true });
      await showImage($("simulate-plot"), plot);
    });
  }

  // ------------------------------------------------------------------ identify
  function parseCsv(text) {
    const lines = text.split(/\r?\n/).map((l) => l.trim()).filter((l) => l && !l.startsWith("#"));
    if (lines.length < 2) throw new Error("the file needs a header and at least one row");
    const head = lines[0].split(/[,;\t]/).map((h) => h.trim().toLowerCase());
    const cols = Object.fromEntries(head.map((h) => [h, []]));
    for (const line of lines.slice(1)) {
      const cells = line.split(/[,;\t]/);
      head.forEach((h, i) => cols[h].push(Number(cells[i])));
    }
    if (["time", "force", "position"].every((h) => h in cols)) {
      const t = cols.time;
      return { kind: "time_series", sample_time: (t[t.length - 1] - t[0]) / (t.length - 1),
               force: cols.force, position: cols.position };
    }
    if (["frequency", "real", "imag"].every((h) => h in cols)) {
      return { kind: "frequency_response", frequency: cols.frequency, real: cols.real, imag: cols.imag };
    }
    throw new Error(`columns ${head.join(", ")}: expected time,force,position or frequency,real,imag`);
  }

  /** A small answer record in words: "white: true, p_value: 0.42" (numbers as the page shows them). */
  function describe(v) {
    if (v === null || v === undefined) return "—";
    if (typeof v !== "object") return typeof v === "number" ? num(v) : String(v);
    return Object.entries(v).filter(([, x]) => x === null || typeof x !== "object")
      .map(([k, x]) => `${k.replaceAll("_", " ")}: ${typeof x === "number" ? num(x, 4) : x}`).join(", ");
  }

  let identified = null;

  async function identify(ev) {
    ev.preventDefault();
    await runPanel($("id-run"), $("identify-result"), async () => {
      const file = $("id-file").files[0];
      if (!file) throw new ApiError(422, { detail: [{ loc: ["body", "data"], msg: "choose a CSV file first" }] });
      let data;
      try { data = parseCsv(await file.text()); } catch (e) {
        throw new ApiError(422, { detail: [{ loc: ["body", "data"], msg: e.message }] });
      }
      const body = { model: $("id-model").value, data, confidence: 0.95 };
      if (data.kind === "time_series") body.friction = $("id-friction").checked;
      else body.sample_time = readDevice().sample_time ?? 0.001;
      const r = await api("/v1/identify", { method: "POST", body });
      identified = r;
      const params = Object.entries(r.parameters || {}).map(([name, p]) =>
        [escapeText(name), `${num(p.value)} ± ${num(p.std_error, 3)} (interval ${num(p.interval[0])} – ${num(p.interval[1])})`]);
      $("identify-result").innerHTML = table([
        ["status", statusBadge(r.status), "identify-status"],
        ["model", escapeText(r.model || "—")],
        ["why", escapeText(r.reason || "—")],
        ...params,
        ["fit NRMSE", r.fit ? num(r.fit.nrmse, 4) : "—"],
        ["residual whiteness", r.fit ? escapeText(describe(r.fit.residual_whiteness)) : "—"],
        ...(r.warnings || []).map((w) => ["warning", escapeText(w)]),
        ["elapsed", withUnit(r.elapsed_ms, "ms", 4)],
      ]) + (r.status !== "failed"
        ? "<button type=\"button\" id=\"id-use\">Use this device</button>" + (r.status === "identified"
          ? " <button type=\"button\" id=\"id-robust\">Safe wall for the whole box</button><div id=\"id-robust-result\"></div>"
          : " (no uncertainty box: the model does not explain these data, see the warnings)")
        : "");
      if (r.status !== "failed") {
        $("id-use").onclick = () => { fillDevice(r.device); $("preset").value = ""; scheduleBoundary(); };
      }
      if (r.status === "identified") {
        $("id-robust").onclick = () => runPanel($("id-robust"), $("id-robust-result"), async () => {
          const d = await api("/v1/design/stiffness", { method: "POST", body: {
            device: identified.device, requirements: { min_gain_margin_db: 6, uncertainty: identified.uncertainty } } });
          $("id-robust-result").innerHTML = table(stiffnessRows(d, "id-robust"));
        });
      }
      if (r.status !== "failed") {
        try {
          await showImage($("identify-plot"), await api("/v1/plots/identify?format=svg", { method: "POST", body, raw: true }));
        } catch { $("identify-plot").hidden = true; }
      }
    });
  }

  // ------------------------------------------------------------------ studies
  let studyTimer = null;

  async function submitStudy(ev) {
    ev.preventDefault();
    $("study-error").textContent = "";
    const device = readDevice();
    const massPath = isCable() ? "device.cable.body_mass" : "device.mass";
    const body = {
      problem: $("sd-problem").value, name: "explorer",
      base: { device, ...($("sd-problem").value === "stability" ? { requirements: { stiffness: 2000 } } : {}) },
      sweep: {
        [massPath]: { start: Number($("sd-mass-min").value), stop: Number($("sd-mass-max").value), num: Number($("sd-mass-num").value) },
        "device.delay": { start: 0, stop: Number($("sd-delay-max").value) * 1e-3, num: Number($("sd-delay-num").value) },
      },
    };
    $("sd-run").disabled = true;
    try {
      await api("/v1/studies", { method: "POST", body });
      await refreshStudies();
    } catch (err) {
      $("study-error").textContent = says(errorsOf(err));
    } finally {
      $("sd-run").disabled = false;
    }
  }

  async function download(id, format) {
    const r = await api(`/v1/studies/${id}/results?format=${format}`, { raw: true });
    const a = document.createElement("a");
    a.href = URL.createObjectURL(await r.blob());
    a.download = `study-${id}.${format}`;
    a.click();
    setTimeout(() => URL.revokeObjectURL(a.href), 5000);
  }

  async function heatmap(study) {
    const res = await api(`/v1/studies/${study.id}/results?limit=50`);
    const ys = ["critical_stiffness", "gain_margin_db", "max_stable_damping"];
    const numeric = (c) => res.rows.some((r) => typeof r[c] === "number");
    const y = ys.find((c) => res.columns.includes(c) && numeric(c))
      || res.columns.find((c) => !study.sweep.includes(c) && c !== "index" && numeric(c))
      || ys.find((c) => res.columns.includes(c));     // none has a number yet: the API says so, with the field
    const [x, x2] = study.sweep;
    const q = new URLSearchParams({ y, x, format: "svg", ...(x2 ? { x2 } : {}) });
    await showImage($("study-plot"), await api(`/v1/studies/${study.id}/plot?${q}`, { raw: true }));
  }

  function studyRow(s) {
    const tr = document.createElement("tr");
    tr.dataset.study = s.id;
    const running = s.status === "running" || s.status === "queued";
    tr.innerHTML = `<td><code>${escapeText(s.id.slice(0, 8))}</code>${s.name ? ` ${escapeText(s.name)}` : ""}</td>
      ${window.zwidthStudies.problemCell(s.problem)}<td>${statusBadge(s.status)}</td>
      <td><progress max="${s.total}" value="${s.done}" aria-label="progress"></progress>
        <span class="progress-text">${s.done}/${s.total}</span></td>
      <td>${num(s.rate, 4)}</td><td>${running ? num(s.eta_s, 3) : "—"}</td><td class="actions"></td>`;
    const actions = tr.querySelector(".actions");
    const add = (label, fn) => {
      const b = document.createElement("button");
      b.type = "button"; b.className = "link"; b.textContent = label;
      b.addEventListener("click", () => fn().catch((err) => {
        $("study-error").textContent = says(errorsOf(err));
      }));
      actions.append(b);
    };
    if (s.done > 0) {
      add("heatmap", () => heatmap(s));
      add("CSV", () => download(s.id, "csv"));
      add("Parquet", () => download(s.id, "parquet"));
    }
    if (running) add("cancel", async () => { await api(`/v1/studies/${s.id}`, { method: "DELETE" }); await refreshStudies(); });
    return tr;
  }

  async function refreshStudies() {
    clearTimeout(studyTimer);
    try {
      const list = await api("/v1/studies?limit=20");
      const body = $("study-table").querySelector("tbody");
      body.replaceChildren(...list.studies.map(studyRow));
      if (list.studies.some((s) => s.status === "running" || s.status === "queued")) {
        studyTimer = setTimeout(refreshStudies, 500);
      }
    } catch (err) {
      $("study-error").textContent = says(errorsOf(err));
    }
  }

  // ------------------------------------------------------------------ tabs (WAI-ARIA tab pattern)
  function selectTab(id) {
    for (const tab of document.querySelectorAll("[role=tab]")) {
      const on = tab.id === id;
      tab.setAttribute("aria-selected", String(on));
      tab.tabIndex = on ? 0 : -1;
      $(tab.getAttribute("aria-controls")).hidden = !on;
      if (on) tab.focus();
    }
    if (id === "tab-studies") refreshStudies();
  }

  function installTabs() {
    const tabs = [...document.querySelectorAll("[role=tab]")];
    tabs.forEach((tab, i) => {
      tab.addEventListener("click", () => selectTab(tab.id));
      tab.addEventListener("keydown", (ev) => {
        const step = { ArrowRight: 1, ArrowLeft: -1 }[ev.key];
        if (step) selectTab(tabs[(i + step + tabs.length) % tabs.length].id);
        if (ev.key === "Home") selectTab(tabs[0].id);
        if (ev.key === "End") selectTab(tabs[tabs.length - 1].id);
      });
    });
  }

  window.zwidthExplorer = { api, errorsOf, showImage };   // for the tabs in their own files (explorer_*.js)

  // ------------------------------------------------------------------ start
  async function start() {
    installTabs();
    syncBlocks();
    $("device-form").addEventListener("input", (ev) => {
      if (ev.target.id === "preset") return;
      if (ev.target.type === "radio" || ev.target.type === "checkbox") syncBlocks();
      syncEffects();
      syncRobustBox();
      scheduleBoundary();
    });
    $("preset").addEventListener("change", () => {
      const p = presets[$("preset").value];
      if (p) fillDevice(p);
      syncEffects();
      syncRobustBox();
      scheduleBoundary();
    });
    $("sim-effects").addEventListener("change", syncEffects);
    $("stiffness-form").addEventListener("submit", designStiffness);
    $("inertia-form").addEventListener("submit", designInertia);
    $("robust-form").addEventListener("submit", designRobust);
    $("hardware-form").addEventListener("submit", designHardware);
    $("simulate-form").addEventListener("submit", simulate);
    $("identify-form").addEventListener("submit", identify);
    $("study-form").addEventListener("submit", submitStudy);
    $("token-button").hidden = !sessionStorage.getItem(TOKEN_KEY);
    $("token-button").addEventListener("click", () => askToken("").then(scheduleBoundary));

    try {
      const health = await fetch("/healthz").then((r) => r.json());
      $("server-status").textContent = `zwidth ${health.version} at ${location.host}`;
    } catch {
      $("server-status").textContent = "the server does not answer";
    }
    presets = await api("/v1/presets");
    for (const name of Object.keys(presets)) $("preset").append(new Option(name, name));
    const first = presets.lhifam ? "lhifam" : Object.keys(presets)[0];
    $("preset").value = first;
    fillDevice(presets[first]);
    syncEffects();
    syncRobustBox();
    document.body.dataset.ready = "true";
    await refreshBoundary();
  }

  window.zwidthExplorer = { readDevice, api, lineChart, num };   // for explorer_<topic>.js (the rendered wall, …)
  document.addEventListener("DOMContentLoaded", start);
})();
