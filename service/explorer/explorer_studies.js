/* zwidth design explorer: the study table's problem names.
 *
 * The API names a study's problem by its identifier (optim.studies.problems.PROBLEMS: `critical_stiffness`, …);
 * the table shows what it computes, with the identifier kept as the cell's tooltip and as a secondary line
 * (what the CLI, the export and the API take).  An identifier this page does not know is shown as it is.
 * Loaded before explorer.js (index.html), which calls window.zwidthStudies.problemCell.
 */
"use strict";
window.zwidthStudies = (() => {
  const PROBLEM_NAMES = Object.freeze({
    critical_stiffness: "critical stiffness K_cr",
    stability: "stability of a wall",
    stiffness: "stiffness design",
    inertia: "inertia design (force feedforward)",
    workspace_critical_stiffness: "K_cr over a multi-DOF workspace",
  });
  const escape = (s) => String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" }[c]));

  /** The readable name of a study problem (its identifier when unknown). */
  const problemName = (problem) => PROBLEM_NAMES[problem] || String(problem);

  /** The table cell (HTML) of a study's problem: the readable name, the identifier as tooltip and second line. */
  function problemCell(problem) {
    const raw = escape(problem);
    const name = problemName(problem);
    if (name === String(problem)) return `<td class="problem" title="${raw}">${raw}</td>`;
    return `<td class="problem" title="${raw}">${escape(name)}<br><small class="raw-name">${raw}</small></td>`;
  }

  return Object.freeze({ PROBLEM_NAMES, problemName, problemCell });
})();
