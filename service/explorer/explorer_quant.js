/* Issue 31 in the explorer: the quantised/friction wall's regime as a coloured band on the boundary plot, and the
 * encoder (friction) answer of the hardware tab.  explorer.js calls window.zwidthQuant.boundary(...) after it draws
 * the boundary and window.zwidthQuant.hardware(...) after it shows a hardware answer; nothing here computes: the
 * regimes are the API's (POST /v1/analysis/stability, its `nonlinear` block). */
"use strict";
(() => {
  const NS = "http://www.w3.org/2000/svg";
  const COLOURS = { passive: "#2e7d32", stable_not_passive: "#9e9d24", limit_cycle: "#ef6c00", unstable: "#c62828",
                    undetermined: "#757575" };
  const FRACTIONS = [0.1, 0.3, 0.5, 0.7, 0.85, 0.95, 1.05];   // K / K_cr(B = 0) where the regime is asked
  let pending = null;

  const fmt = (v, digits = 4) => (v === null || v === undefined || !Number.isFinite(v) ? "—"
    : Number(v).toPrecision(digits));

  // lineChart's frame (explorer.js): W 760, H 340, margins L 78, T 14, B 46; y from 0 to 1.15 × the largest K_cr
  const H = 340, L = 78, T = 14, B = 46;

  function band(svg, rows, kTop) {
    const g = document.createElementNS(NS, "g");
    g.setAttribute("class", "regime-band");
    const sy = (k) => H - B - (Math.min(k, kTop) / kTop) * (H - T - B);
    let lo = 0;
    for (const r of rows) {
      const hi = r.k;
      const rect = document.createElementNS(NS, "rect");
      rect.setAttribute("x", L + 1); rect.setAttribute("width", 12);
      rect.setAttribute("y", sy(hi)); rect.setAttribute("height", Math.max(1, sy(lo) - sy(hi)));
      rect.setAttribute("fill", COLOURS[r.regime] || "#bdbdbd");
      rect.setAttribute("opacity", "0.8");
      rect.setAttribute("data-regime", r.regime || "none");
      const t = document.createElementNS(NS, "title");
      t.textContent = `K up to ${fmt(hi)} N/m at B = 0: ${r.regime}` + (r.reason ? ` (${r.reason})` : "");
      rect.append(t);
      g.append(rect);
      lo = hi;
    }
    svg.append(g);
  }

  function legend(container, rows) {
    let p = container.parentElement.querySelector(".regime-legend");
    if (!p) {
      p = document.createElement("p");
      p.className = "regime-legend";
      p.id = "regime-legend";
      container.after(p);
    }
    p.textContent = rows.length ? "Regime at B = 0 (the coloured band on the K axis; green passive, olive stable "
      + "not passive, orange limit cycle, red unstable, grey undetermined): " + rows
      .map((r) => `K ≤ ${fmt(r.k)} N/m ${r.regime}`).join("; ") : "";
  }

  async function boundary(container, bd, device, api) {
    if (pending) pending.abort();
    const has = device.encoder_resolution !== undefined || device.coulomb_friction !== undefined;
    if (!has) { legend(container, []); return; }
    const k0 = bd.points && bd.points.length ? bd.points[0].critical_stiffness : null;
    if (!Number.isFinite(k0)) return;
    const ctl = new AbortController();
    pending = ctl;
    try {
      const rows = [];
      for (const f of FRACTIONS) {     // one after another: each is a describing-function scan
        const r = await api("/v1/analysis/stability", { method: "POST", signal: ctl.signal,
          body: { device, controller: { stiffness: f * k0 } } });
        const nl = r.nonlinear || {};
        rows.push({ k: f * k0, regime: nl.regime, reason: nl.reason });
      }
      const svg = container.querySelector("svg");
      const kTop = 1.15 * Math.max(...bd.points.map((p) => p.critical_stiffness).filter(Number.isFinite));
      if (svg) band(svg, rows, kTop);
      legend(container, rows);
    } catch (err) {
      if (err.name !== "AbortError") legend(container, []);
    }
  }

  function hardware(container, r) {
    const q = r.quantisation;
    if (!q) return;
    const answer = r.value === null ? "—" : r.free === "encoder_resolution"
      ? `${fmt(r.value * 1e6, 4)} µm per count` : `${fmt(r.value, 6)} N`;
    const lines = [
      [r.free === "encoder_resolution" ? "coarsest encoder q" : "least friction f_c", answer, "hardware-encoder"],
      ["counts over the travel", q.counts_over_travel === null ? "— (give device.travel)" : fmt(q.counts_over_travel, 6),
       "hardware-counts"],
      ["sampling term (no encoder changes it)", `${fmt(q.sampling_term, 6)} N/m`],
      ["checked by the nonlinear analysis", q.confirmed ? "yes: passive at the answer, not 1 % looser" : "no",
       "hardware-confirmed"],
      ["source", q.source + (q.covered ? "" : " (covered: false)")],
    ];
    const table = document.createElement("table");
    table.className = "facts";
    for (const [k, v, id] of lines) {
      const tr = document.createElement("tr");
      const th = document.createElement("th"); th.textContent = k;
      const td = document.createElement("td"); td.textContent = v;
      if (id) td.id = id;
      tr.append(th, td);
      table.append(tr);
    }
    container.append(table);
  }

  window.zwidthQuant = { boundary, hardware };
})();
