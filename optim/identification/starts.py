"""Starting points for the fit: the cost is multimodal in the delay (FIELD-NOTES.md), so one start per
whole sample of delay, each with its mass and offset solved linearly.

Rigid, time series: at a fixed delay and δ = bT/m the encoder position is (T²/m)·s(δ, t_d; u) + offset
(+ (F_c/m)·T²·s_f), linear in 1/m, the offset and F_c/m; a grid of δ per delay gives the best start of
that sample.  Rigid, frequency response: at a fixed delay, e^{−jωt_d}/H = −mω² + jbω is linear in m, b.
Cable: from the rigid fit, the resonance ω_n and anti-resonance ω_z read from the empirical transfer
function divided by the rigid model (μ_r = (ω_z/ω_n)², k_c = ω_z²·m_d), at the rigid fit's delay and
the whole samples around it.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import csd, welch

from optim.identification.data import FrequencyResponseData, TimeSeriesData
from optim.identification.models import device_from, response, simulate_position
from optim.identification.problem import Problem

__all__ = ["cable_starts", "rigid_starts"]

_DELTAS = np.geomspace(1e-7, 0.3, 16)


def _rigid_ts_score(prob: Problem, delay: float, delta: float) -> tuple[float, dict[str, float]] | None:
    t = prob.sample_time
    data = prob.data
    dev = device_from("rigid", {"mass": 1.0, "damping": delta / t, "delay": delay}, t)
    cols = [simulate_position(dev, data.force), np.ones(len(data.force))]
    if prob.friction:
        dev0 = device_from("rigid", {"mass": 1.0, "damping": delta / t, "delay": 0.0}, t)
        cols.append(simulate_position(dev0, prob.sign_regressor))
    a = np.column_stack(cols)
    coef, *_ = np.linalg.lstsq(a, data.position, rcond=None)
    if not coef[0] > 0:
        return None
    r = a @ coef - data.position
    mass = 1.0 / coef[0]
    vals = {"mass": mass, "damping": delta * mass / t, "delay": delay, "offset": float(coef[1])}
    if prob.friction:
        vals["friction"] = max(float(coef[2]) * mass, 0.0)
    return float(r @ r), vals


def _rigid_fr_score(prob: Problem, delay: float) -> tuple[float, dict[str, float]] | None:
    data = prob.data
    w = data.frequency
    g = np.exp(-1j * w * delay) / data.response          # = −mω² + jbω for the continuous rigid model
    a = np.concatenate([-w ** 2, np.zeros_like(w)])
    bcol = np.concatenate([np.zeros_like(w), w])
    wt = np.concatenate([np.abs(data.response)] * 2)      # equation error weighted like the output error
    lhs = np.column_stack([a, bcol]) * wt[:, None]
    coef, *_ = np.linalg.lstsq(lhs, np.concatenate([g.real, g.imag]) * wt, rcond=None)
    m, b = float(coef[0]), max(float(coef[1]), 0.0)
    if not m > 0:
        return None
    vals = {"mass": m, "damping": b, "delay": delay}
    x = np.array([vals[n] for n in prob.names])
    try:
        r = prob.residual(x)
    except ValueError:
        return None
    return float(r @ r), vals


def rigid_starts(prob: Problem, max_delay: float) -> list[tuple[float, dict[str, float], tuple[float, float]]]:
    """(score, start values, delay bounds of its sample) for every whole sample of delay, best first."""
    t = prob.sample_time
    out = []
    fixed_delay = prob.fixed.get("delay")
    delays = [fixed_delay] if fixed_delay is not None else \
        [k * t for k in range(int(math.floor(max_delay / t + 1e-9)) + 1)]
    for dl in delays:
        bounds = (max(0.0, dl - 0.5 * t), dl + 0.5 * t)
        if isinstance(prob.data, TimeSeriesData):
            # two points per sample (a quarter sample either side): at whole samples only, a fast chirp can
            # rank a wrong sample first when the true delay sits half-way between two
            offsets = (0.0,) if fixed_delay is not None else (-0.25 * t, 0.25 * t)
            cands = [_rigid_ts_score(prob, max(dl + o, 0.0), delta) for o in offsets for delta in _DELTAS]
        else:
            cands = [_rigid_fr_score(prob, dl)]
        cands = [c for c in cands if c is not None]
        if cands:
            best = min(cands, key=lambda c: c[0])
            out.append((best[0], best[1], bounds))
    out.sort(key=lambda c: c[0])
    return out


def _resonance(prob: Problem, rigid: dict[str, float]) -> list[tuple[float, float]]:
    """(ω_n, ω_z) candidates [rad/s] from the data divided by the rigid model's response."""
    t = prob.sample_time
    dev = device_from("rigid", {k: rigid[k] for k in ("mass", "damping", "delay")}, t)
    if isinstance(prob.data, TimeSeriesData):
        u, y = prob.data.force, prob.data.position
        nper = int(min(len(u), 512))
        f, puu = welch(u, fs=1 / t, nperseg=nper, detrend="linear")
        _, pyu = csd(u, y, fs=1 / t, nperseg=nper, detrend="linear")
        _, pyy = welch(y, fs=1 / t, nperseg=nper, detrend="linear")
        w = 2 * math.pi * f[1:]
        h = pyu[1:] / puu[1:]
        coherence = np.abs(pyu[1:]) ** 2 / np.maximum(puu[1:] * pyy[1:], 1e-300)
        # only where the position still carries the input (at high frequency it is the encoder's noise)
        ok = (puu[1:] > 1e-3 * np.max(puu[1:])) & (w * t < 0.9 * math.pi) & (coherence > 0.8)
        w, h = w[ok], h[ok]
        kind = "sampled"
    else:
        w, h = prob.data.frequency, prob.data.response
        kind = prob.data.model_kind
        dev = _low_frequency_rigid(prob)
    cands = []
    if len(w) >= 4 and dev is not None:
        ratio = np.abs(h / response(dev, w, kind))
        ip = int(np.argmax(ratio))
        band = (w >= 0.1 * w[ip]) & (w < w[ip])      # μ_r = (ω_z/ω_n)² ≥ 0.01
        if ratio[ip] > 1.3 and band.any():
            iz = int(np.flatnonzero(band)[np.argmin(ratio[band])])
            if ratio[iz] < ratio[ip] and w[iz] < w[ip]:
                cands.append((float(w[ip]), float(w[iz])))
    nyq = math.pi / t
    cands += [(frac * nyq, frac * nyq * math.sqrt(0.9)) for frac in (0.15, 0.4)] if not cands else []
    return cands


def _low_frequency_rigid(prob: Problem):
    """The rigid model fitted (magnitude only, so the delay does not matter) to the lowest third of a
    response's frequencies, below a cable mode: the reference the resonance is read against."""
    data = prob.data
    order = np.argsort(data.frequency)
    low = order[:max(3, len(order) // 3)]
    w, mag = data.frequency[low], np.abs(data.response[low])
    # |1/H|² = m²ω⁴ + b²ω²: linear in (m², b²)
    coef, *_ = np.linalg.lstsq(np.column_stack([w ** 4, w ** 2]) * mag[:, None] ** 2, np.ones_like(w), rcond=None)
    if not coef[0] > 0:
        return None
    return device_from("rigid", {"mass": math.sqrt(coef[0]), "damping": math.sqrt(max(coef[1], 0.0)), "delay": 0.0},
                       prob.sample_time)


def cable_starts(prob: Problem, rigid: dict[str, float], max_delay: float) -> list[dict[str, float]]:
    t = prob.sample_time
    m, b = rigid["mass"], rigid["damping"]
    out = []
    fixed_delay = prob.fixed.get("delay")
    d0 = int(round(rigid["delay"] / t))
    if fixed_delay is not None:
        delays = [fixed_delay]
    elif isinstance(prob.data, FrequencyResponseData):      # cheap to evaluate: every whole sample
        delays = [k * t for k in range(int(math.floor(max_delay / t + 1e-9)) + 1)]
    else:
        delays = sorted({max(0, d0 + k) * t for k in (-1, 0, 1)})
    if isinstance(prob.data, FrequencyResponseData):
        ref = _low_frequency_rigid(prob)
        if ref is not None:
            m, b = ref.mass, ref.damping
    for wn, wz in _resonance(prob, rigid):
        mu_r = min(max((wz / wn) ** 2, 0.01), 0.9)
        m_r, m_d = mu_r * m, (1 - mu_r) * m
        k_c = wz ** 2 * m_d
        b_c = 2 * 0.05 * math.sqrt(k_c * m_r * m_d / m)
        for dl in delays:
            v = {"cable.motor_mass": m_r, "cable.motor_damping": mu_r * b, "cable.body_mass": m_d,
                 "cable.body_damping": (1 - mu_r) * b, "cable.stiffness": k_c, "cable.damping": b_c,
                 "delay": dl}
            if "offset" in rigid:
                v["offset"] = rigid["offset"]
            if "friction" in rigid:
                v["friction"] = rigid["friction"]
            out.append(v)
    return out
