/* zwidth design explorer: the Workspace tab (multi-DOF devices, docs/workspace.md).
 *
 * The map is the service's own figure (POST /v1/plots/workspace: K_cr over two joints, the worst normal's
 * direction), and the numbers beside it are POST /v1/analysis/workspace's answer over a Latin hypercube of poses.
 * The page computes nothing; the API's 422 messages are shown as they come.  The API helpers are explorer.js's
 * (window.zwidthExplorer).
 */
"use strict";
(() => {
  const $ = (id) => document.getElementById(id);

  function request() {
    const num = (id) => Number($(id).value);
    const device = { sample_time: num("ws-sample-time") / 1e3, delay: num("ws-delay") / 1e3,
                     kinematics: { preset: $("ws-preset").value } };
    const b = num("ws-damping");
    return { device, controller: b > 0 ? { stiffness: 1.0, damping: b } : undefined };
  }

  function row(label, value, unit) {
    const tr = document.createElement("tr");
    for (const text of [label, value, unit || ""]) {
      const td = document.createElement("td");
      td.textContent = text;
      tr.append(td);
    }
    return tr;
  }

  async function draw(ev) {
    ev.preventDefault();
    const ui = window.zwidthExplorer;
    const { device, controller } = request();
    $("ws-error").textContent = "";
    $("ws-result").textContent = "mapping…";
    $("ws-run").disabled = true;
    try {
      const plotBody = { device, controller, x_joint: Number($("ws-x").value), y_joint: Number($("ws-y").value),
                         points: Number($("ws-points").value), normals: "worst" };
      const mapBody = { device, controller, normals: "worst",
                        poses: { latin_hypercube: { samples: Number($("ws-poses").value), seed: 1 } } };
      const [image, map] = await Promise.all([
        ui.api("/v1/plots/workspace?format=svg", { method: "POST", body: plotBody, raw: true }),
        ui.api("/v1/analysis/workspace", { method: "POST", body: mapBody })]);
      await ui.showImage($("ws-plot"), image);
      const w = map.worst;
      const table = document.createElement("table");
      table.append(
        row("lowest K_cr over the poses", map.minimum_critical_stiffness === null ? "every K"
          : map.minimum_critical_stiffness.toPrecision(6), "N/m"),
        row("at pose", w.pose.map((x) => x.toFixed(4)).join(", "), "rad"),
        row("along normal", w.normal.map((x) => x.toFixed(4)).join(", "), ""),
        row("effective mass there", w.effective_mass.toPrecision(5), "kg"),
        row("1-DOF approximation's K_cr", w.one_dof_critical_stiffness === null ? "—"
          : w.one_dof_critical_stiffness.toPrecision(6), "N/m"),
        row("poses answered", String(map.points.length), ""),
        row("note", map.note, ""));
      $("ws-result").textContent = "";
      $("ws-result").append(table);
    } catch (err) {
      $("ws-result").textContent = "";
      $("ws-error").textContent = ui.errorsOf(err).map((e) => (e.path.length ? e.path.join(".") + ": " : "") + e.msg)
        .join("; ");
    } finally {
      $("ws-run").disabled = false;
    }
  }

  document.addEventListener("DOMContentLoaded", () => {
    if ($("workspace-form")) $("workspace-form").addEventListener("submit", draw);
  });
})();
