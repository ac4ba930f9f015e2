"""The ``critical_stiffness`` and ``stability`` problems on a chunk of rigid points as columns (issue 20).

A chunk whose base device is a plain rigid device (no preset, no cable) and whose swept paths are among the
rigid device's numbers (mass, damping, sample_time, delay) and the wall (requirements.stiffness, .damping) is
evaluated without a ``Device`` or a dict per point: the swept values are columns, each point is checked
against the same rules as ``models.device.Device`` (the field bounds read from the model, and its cost
limit), the numerics run on the arrays (``optim.robust.batch.rigid_critical_stiffness``, the same fast path
and scan as the per-point path) and the results come back as columns.

Each number is computed by the same floating-point operations, in the same order, as
``optim.studies.critical_study.row`` and ``stability_study._full`` compute it for one point, so a point's
results are bit for bit those of the per-point path, whatever chunk it is in (tests/service/
test_studies_blocks.py holds both paths against each other, through the blocks they are stored as).
A point that any rule refuses is left to the per-point path (``evaluate_chunk``), which words its error;
a chunk the columns cannot take at all gives None.
"""

from __future__ import annotations

import math
from typing import Any, Mapping, Sequence

import annotated_types as at
import numpy as np

from models.device import MAX_DELAY_SAMPLES, Device
from models.discretize import split_delay
from optim.errors import InputError
from optim.robust.batch import rigid_critical_stiffness
from optim.stability.analysis import EXACT_REL_ERROR
from optim.stability.passivity import batch_required_damping

__all__ = ["Columns", "evaluate_columns", "critical_columns", "scatter_columns", "COLUMN_PATHS"]

#: swept paths the column path takes
COLUMN_PATHS = ("device.mass", "device.damping", "device.sample_time", "device.delay",
                "requirements.stiffness", "requirements.damping")
_DEVICE_FIELDS = ("mass", "damping", "sample_time", "delay")

_NO_DAMPING = ("no physical or virtual damping: no positive stiffness is stable "
               "(linear condition α < 2(δ+β)/(1+2d) with δ = β = 0)")
_NO_CROSSOVER = "no phase crossover: every positive stiffness is stable"
_NAN = "device: the parameters are outside the numerically representable range (K_cr is NaN)"

#: result key -> (values: float64/bool ndarray or a list of objects, valid: bool ndarray, None when all are)
Columns = dict[str, tuple[Any, np.ndarray | None]]


def _field_ok(name: str, v: np.ndarray) -> np.ndarray:
    """The bounds pydantic checks on Device.<name> (read from the model), for many values at once."""
    ok = np.isfinite(v)
    for rule in Device.model_fields[name].metadata:
        if isinstance(rule, at.Gt):
            ok &= v > rule.gt
        elif isinstance(rule, at.Ge):
            ok &= v >= rule.ge
        elif isinstance(rule, at.Lt):
            ok &= v < rule.lt
        elif isinstance(rule, at.Le):
            ok &= v <= rule.le
        else:   # a rule this module does not know: leave every point to the per-point path
            ok &= False
    return ok


def _plain_rigid(device: Mapping[str, Any]) -> Device | None:
    if "preset" in device or device.get("cable") is not None:
        return None
    try:
        return Device.model_validate(dict(device))
    except ValueError:
        return None


def evaluate_columns(problem: str, device: Mapping[str, Any], requirements: Mapping[str, Any],
                     axes: Sequence[tuple[str, str]], values: np.ndarray, make_devices
                     ) -> tuple[np.ndarray, Columns, list[str | None]] | None:
    """(handled, columns, errors) of the chunk's points, or None when the chunk is not for the column path.

    ``handled[i]`` is False for a point left to the per-point path (its columns hold nothing); ``errors[i]``
    is the reason of a handled point that failed (its columns hold nothing either).  ``make_devices(rows)``
    gives the validated Devices of some points (for the rows the fast path leaves to the scan)."""
    if problem not in ("critical_stiffness", "stability"):
        return None
    if device.get("cable") is not None or "preset" in device:
        # damped cables, critical_stiffness: optim.studies.cable_columns (the same Devices and batch, as columns)
        from optim.studies.cable_columns import evaluate_cable_columns
        return evaluate_cable_columns(problem, device, requirements, axes, values)
    if any(p not in COLUMN_PATHS for p, _ in axes):
        return None
    base = _plain_rigid(device)
    if base is None or base.cable is not None or set(requirements) - {"stiffness", "damping"}:
        return None
    for key in ("stiffness", "damping"):
        v = requirements.get(key)
        if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v)):
            return None
    values = np.asarray(values, float).reshape(len(values), len(axes))
    n = values.shape[0]
    cols = {name: np.full(n, float(getattr(base, name))) for name in _DEVICE_FIELDS}
    handled = np.ones(n, bool)
    req: dict[str, np.ndarray | None] = {}
    for key in ("stiffness", "damping"):
        v = requirements.get(key)
        req[key] = None if v is None else np.full(n, float(v))
    for j, (path, _) in enumerate(axes):
        group, name = path.split(".", 1)
        if group == "device":
            cols[name] = values[:, j].copy()
            handled &= _field_ok(name, cols[name])
        else:
            req[name] = values[:, j].copy()
    with np.errstate(all="ignore"):
        handled &= ~(cols["delay"] / cols["sample_time"] > MAX_DELAY_SAMPLES)   # Device._cost_limit
        if req["stiffness"] is not None:
            handled &= np.isfinite(req["stiffness"]) & (req["stiffness"] > 0)
        if req["damping"] is not None:
            handled &= np.isfinite(req["damping"]) & (req["damping"] >= 0)
    rows = np.flatnonzero(handled)
    m, bp, t, td = (cols[name][rows] for name in _DEVICE_FIELDS)
    b = req["damping"][rows] if req["damping"] is not None else np.zeros(len(rows))
    k = req["stiffness"][rows] if req["stiffness"] is not None else None
    try:
        with np.errstate(all="ignore"):
            res = rigid_critical_stiffness(m, bp, t, td, b, lambda sub: make_devices([int(rows[i]) for i in sub]))
    except (ArithmeticError, ValueError, InputError):
        return None   # the per-point path bisects down to the point that raises
    sub_cols, sub_err = critical_columns(problem, m, bp, t, td, b, k, res)
    out, errors = scatter_columns(n, rows, sub_cols, sub_err)
    return handled, out, errors


def scatter_columns(n: int, rows: np.ndarray, sub_cols: Columns, sub_err: list[str | None]
                    ) -> tuple[Columns, list[str | None]]:
    """The columns and errors of the points ``rows`` (of a chunk of n) placed at their rows; the others hold nothing."""
    out: Columns = {}
    for key, (vals, valid) in sub_cols.items():
        if isinstance(vals, list):
            full: Any = [None] * n
            for i, v in zip(rows.tolist(), vals):
                full[i] = v
        else:
            full = np.zeros(n, vals.dtype)
            full[rows] = vals
        ok = np.zeros(n, bool)
        ok[rows] = True if valid is None else valid
        out[key] = (full, ok)
    errors: list[str | None] = [None] * n
    for i, e in zip(rows.tolist(), sub_err):
        errors[i] = e
    return out, errors


def critical_columns(problem: str, m, bp, t, td, b, k, res) -> tuple[Columns, list[str | None]]:
    """The results of points as columns, from their K_cr, crossover angle and B_max (``res``), physical damping ``bp``,
    sample time ``t``, delay ``td``, wall B ``b`` and K ``k`` (None: no wall stiffness): the floating-point operations
    of critical_study.row (and, for ``stability``, stability_study's rigid rows), elementwise.  ``m`` (the mass) is
    not read.  Also the errors (a NaN fails its point)."""
    kcr, ang, bmax = res.critical_stiffness, res.crossover_angle, res.max_stable_damping
    n = len(kcr)
    good = ~(np.isnan(kcr) | np.isnan(bmax))            # critical_study.row: a NaN fails its point
    errors: list[str | None] = [None if g else _NAN for g in good.tolist()]
    with np.errstate(all="ignore"):
        pos = (kcr > 0) & np.isfinite(kcr)
        freq = ang / t
        lin = (bp + b) / (t / 2 + td)                   # optim.stability.margins.linear_estimate
        ratio = kcr / k if k is not None else None
    reason: list[str | None] = [None] * n
    for i in np.flatnonzero(good & ((kcr == 0.0) | np.isinf(kcr))).tolist():
        if kcr[i] == 0.0:
            reason[i] = (_NO_DAMPING if bp[i] + b[i] <= 0.0 else
                         f"virtual damping B = {float(b[i]):.6g} N·s/m is at or above the largest stable virtual "
                         f"damping B_max = {float(bmax[i]):.6g} N·s/m for this delay: no positive stiffness is stable")
        else:
            reason[i] = _NO_CROSSOVER
    crit = (kcr, good & np.isfinite(kcr))
    cross = (freq, good & pos & np.isfinite(freq))
    bmx = (bmax, good & np.isfinite(bmax))
    lin_ok = good & np.isfinite(lin)
    gm = stable = None
    if k is not None:
        stable = (k < kcr, good)
        has_gm = good & (kcr > 0.0) & (kcr < math.inf)
        gm_vals = np.zeros(n)
        for i in np.flatnonzero(has_gm).tolist():       # optim.stability.margins.gain_margin_db, one by one
            gm_vals[i] = 20.0 * math.log10(ratio[i])
        gm = (gm_vals, has_gm)
    if problem == "critical_stiffness":
        out: Columns = {"critical_stiffness": crit, "crossover_frequency": cross, "max_stable_damping": bmx,
                        "linear_estimate": (lin, lin_ok)}
        if k is not None:
            out["stable"], out["gain_margin_db"] = stable, gm
        out["reason"] = (reason, good)
        return out, errors
    none = np.zeros(n, bool)
    req_d = np.full(n, np.nan)
    conservative = np.zeros(n, bool)
    if k is not None:
        ds = td / t                                        # Device.delay_samples
        used = {}
        for v in np.unique(ds[good]).tolist():             # optim.stability.passivity.passivity_samples
            d, f = split_delay(v)
            used[v] = (d + 1, True) if f > 0 else (d, False)
        d_of = np.array([used.get(v, (0, False))[0] for v in ds.tolist()], np.int64)
        conservative = np.array([used.get(v, (0, False))[1] for v in ds.tolist()], bool)
        for d in sorted({used[v][0] for v in used}):
            idx = np.flatnonzero(good & (d_of == d))
            if len(idx):
                # passivity depends on K·T/2, B and d alone (not on mass or damping): each distinct pair is
                # searched once (a row's search never depends on the other rows, so this is exact), by bits
                half_tk, bb = k[idx] * t[idx] / 2, b[idx]
                keys = np.column_stack([half_tk.view(np.uint64), bb.view(np.uint64)])
                uniq, first, inv = np.unique(keys, axis=0, return_index=True, return_inverse=True)
                req_d[idx] = batch_required_damping(d, half_tk[first], bb[first])[0][inv.reshape(-1)]
    with np.errstate(all="ignore"):
        lin_err = np.abs(lin / kcr - 1)
    out = {"critical_stiffness": crit, "crossover_frequency": cross, "damping": (b.copy(), good),
           "stiffness": (k.copy(), good) if k is not None else (np.zeros(n), none),
           "gain_margin_db": gm if k is not None else (np.zeros(n), none),
           "stable": stable if k is not None else (np.zeros(n, bool), none),
           "passive": (bp > req_d, good) if k is not None else (np.zeros(n, bool), none),
           "passivity_required_damping": (req_d, good) if k is not None else (np.zeros(n), none),
           "passivity_conservative": (conservative, good),
           "linear_estimate": (lin, lin_ok),
           "linear_error": (lin_err, lin_ok & (kcr > 0.0) & (kcr < math.inf)),
           "max_stable_damping": bmx,
           "q_criterion": (np.zeros(n), none), "mode_matters": (np.zeros(n, bool), none),
           "rigid_critical_stiffness": (np.zeros(n), none),
           "error_estimate": (np.full(n, EXACT_REL_ERROR), good),
           "reason": (reason, good)}
    return out, errors
