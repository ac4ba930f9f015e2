"""Extended-precision reference for K_f,cr (the ``reference`` rung of the force-feedforward loop; slow by design).

An implementation independent of the double-precision path (models/feedforward.py,
models/discretize.py, models/filters.py, optim/stability/crossovers.py): it shares no
numerical code with them.

* G_1 is built as a rational function of s from the chapter's blocks (eq. 29-31):
  rigid  Z_h/(m s² + b s + Z_h), cable  Z_h·G_c/(1 + Z_h·G_d) (eq. 15-18 over the
  common denominator), times the sensor filter 1/(1 + T_f s).  It is sampled by
  residues (the modified z-transform with ZOH and delay (d + f)T, m = 1 − f):

      G_1(z) = z^{−d}(1 − z⁻¹) z⁻¹ Σ_p Res_p[G(s)/s · e^{msT} · z/(z − e^{sT})],

  the poles of G(s)/s found by mpmath.polyroots at ``digits`` + guard digits.
  A proper (not strictly proper) G — rigid device, no sensor filter — has a direct
  term c that acts through u[k−d−1] (the sensor reads just before the hold
  updates, kT⁻; models/feedforward.py explains the convention): c·z^{−d−1}.
* D(z) is the analog Butterworth Π(−p_k)/(s − p_k) with p_k on the circle of
  radius ω_a = (2/T)·tan(ω_c T/2) (prewarping), at s = (2/T)(z − 1)/(z + 1).
* The crossings of h = −1/(D·G_1) with the positive real axis are searched on
  h̃ = −conj(D·G_1) (same phase, finite where D vanishes at z = −1) over a grid of
  its own (log part, a linear part fine for the delay's phase, clusters around
  lightly damped poles and zeros and a log band around the cutoff) and bisected
  to ``digits`` digits; K_f = 1/|D·G_1| there.

Cost cap: the grid grows with the delay (about 12 samples per radian of the
delay's phase turn); delays above REFERENCE_FORCE_GAIN_MAX_DELAY_SAMPLES are refused.
A device without physical or grasp damping would put poles on the unit circle;
that case is not a reference case and is refused too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mpmath as mp

from models.device import Device, Human
from optim.errors import InputError

__all__ = ["FeedforwardReference", "reference_critical_force_gain", "reference_g1",
           "REFERENCE_FORCE_GAIN_MAX_DELAY_SAMPLES", "REFERENCE_DIGITS"]

#: Cap of the 40-digit K_f,cr rung (any caller): its scan grows linearly with the delay in samples (docs/limits.md).
REFERENCE_FORCE_GAIN_MAX_DELAY_SAMPLES = 500
REFERENCE_DIGITS = 40
_GUARD = 20


@dataclass(frozen=True)
class FeedforwardReference:
    critical_force_gain: float
    """K_f,cr [dimensionless]; inf when no crossing exists."""
    crossover_frequency: float | None
    """ω [rad/s] of the crossing that sets it."""
    crossovers: tuple[tuple[float, float], ...]
    """(ω [rad/s], K_f) of every crossing with K_f > 0."""
    digits: int
    evaluations: int
    """How many times G_1·D was evaluated (the cost)."""


def _pmul(a, b):
    out = [mp.mpf(0)] * (len(a) + len(b) - 1)
    for i, x in enumerate(a):
        for j, y in enumerate(b):
            out[i + j] += x * y
    return out


def _padd(a, b):
    n = max(len(a), len(b))
    a, b = [mp.mpf(0)] * (n - len(a)) + list(a), [mp.mpf(0)] * (n - len(b)) + list(b)
    return [x + y for x, y in zip(a, b)]


def _trim(p):
    while len(p) > 1 and p[0] == 0:
        p = p[1:]
    return p


def _transfer(device: Device, human: Human) -> tuple[list, list]:
    """(num, den) of G(s) = Z_h·G_c/(1 + Z_h·G_d)·G_f, coefficients highest power first."""
    zh = [mp.mpf(human.mass), mp.mpf(human.damping), mp.mpf(human.stiffness)]
    if device.cable is None:
        num, den = zh, _padd([mp.mpf(device.mass), mp.mpf(device.damping), 0], zh)
    else:
        c = device.cable
        p_r = [mp.mpf(c.motor_mass), mp.mpf(c.motor_damping) + mp.mpf(c.damping), mp.mpf(c.stiffness)]
        p_d = [mp.mpf(c.body_mass), mp.mpf(c.body_damping) + mp.mpf(c.damping), mp.mpf(c.stiffness)]
        link = [mp.mpf(c.damping), mp.mpf(c.stiffness)]
        # G_d = p_r/P, G_c = link/P with P = p_r·p_d − link²: Z_h G_c/(1 + Z_h G_d) = Z_h·link/(P + Z_h·p_r)
        num, den = _pmul(zh, link), _padd(_padd(_pmul(p_r, p_d), [-x for x in _pmul(link, link)]), _pmul(zh, p_r))
    tf = mp.mpf(device.force_sensor.time_constant) if device.force_sensor is not None else mp.mpf(0)
    num, den = _trim(num), _trim(_pmul(den, [tf, 1]))
    # no grasp stiffness: num and den share the factor s (position unobservable); cancel it
    while num[-1] == 0 and den[-1] == 0:
        num, den = num[:-1], den[:-1]
    return num, den


class _G1:
    """G_1(e^{jθ}) by residues; poles computed once."""

    def __init__(self, device: Device, human: Human):
        num, den = _transfer(device, human)
        self.t = mp.mpf(device.sample_time)
        self.direct = mp.mpf(0)
        if len(num) == len(den):
            # proper: G = c + G_sp, c acts through u[k-d-1] (kT⁻ sampling)
            self.direct = num[0] / den[0]
            num = _trim(_padd(num, [-self.direct * x for x in den]))
        den_s = den + [mp.mpf(0)]                                  # G(s)/s
        self.poles = mp.polyroots(den_s[::-1], maxsteps=800, extraprec=400, asc=True)
        dden = [x * (len(den_s) - 1 - i) for i, x in enumerate(den_s[:-1])]
        self.residues = [mp.polyval(num[::-1], p, asc=True) / mp.polyval(dden[::-1], p, asc=True) for p in self.poles]
        self.zeros = mp.polyroots(num[::-1], maxsteps=800, extraprec=400, asc=True) if len(num) > 1 else []
        delay = mp.mpf(device.delay) / self.t
        self.d = int(mp.floor(delay + mp.mpf(10) ** (-30)))
        frac = delay - self.d
        self.f = frac if frac > mp.mpf(10) ** (-30) else mp.mpf(0)
        m_ = 1 - self.f
        self.weights = [r * mp.exp(m_ * p * self.t) for r, p in zip(self.residues, self.poles)]
        self.exps = [mp.exp(p * self.t) for p in self.poles]

    def __call__(self, z):
        acc = mp.mpc(0)
        for w, e in zip(self.weights, self.exps):
            acc += w * z / (z - e)
        return z ** (-self.d) * ((1 - 1 / z) / z * acc + self.direct / z)


def _butterworth(order: int, cutoff_hz: float, sample_time: float):
    t = mp.mpf(sample_time)
    wa = 2 / t * mp.tan(mp.pi * mp.mpf(cutoff_hz) * t)             # prewarped analog cutoff
    poles = [wa * mp.expj(mp.pi * (2 * k + order - 1) / (2 * order)) for k in range(1, order + 1)]

    def d(z):
        s = 2 / t * (z - 1) / (z + 1)
        out = mp.mpc(1)
        for p in poles:
            out *= -p / (s - p)
        return out
    return d


def reference_g1(device: Device, human: Human, theta: float, digits: int = REFERENCE_DIGITS) -> complex:
    """G_1(e^{jθ}) at ``digits`` digits (rounded to complex), for tests of other discretisations."""
    with mp.workdps(digits + _GUARD):
        return complex(_G1(device, human)(mp.expj(mp.mpf(theta))))


def _bisect(f, lo, hi, flo, digits: int):
    tol = mp.mpf(10) ** (-digits - 2) * hi
    n = 0
    while hi - lo > tol:
        mid = (lo + hi) / 2
        fm = f(mid)
        n += 1
        if fm == 0:
            return mid, n
        if mp.sign(fm) == mp.sign(flo):
            lo, flo = mid, fm
        else:
            hi = mid
    return (lo + hi) / 2, n


def _angles_of(roots, t) -> list[float]:
    """Folded angles |Im(r)·T| of lightly damped (ζ < 0.2) roots, in (0, π]."""
    out = []
    for r in roots:
        r = mp.mpc(r)
        if mp.im(r) != 0 and -mp.re(r) < 0.2 * abs(r):
            a = math.fmod(float(abs(mp.im(r)) * t), 2 * math.pi)
            out.append(2 * math.pi - a if a > math.pi else a)
    return out


def _grid(g1: _G1, cutoff_angle: float | None) -> list[float]:
    t = float(g1.t)
    rates = [float(abs(p)) * t for p in g1.poles if abs(p) > 0] + [float(abs(z)) * t for z in g1.zeros if abs(z) > 0]
    rates.append(1.0 / (g1.d + 2.0))
    if cutoff_angle is not None:
        rates.append(cutoff_angle)
    lo = max(1e-9, 1e-2 * min(rates))
    top = 0.05
    pts = [lo * (top / lo) ** (i / 200) for i in range(201)] if lo < top else []
    step = min(0.01, math.pi / (12 * (g1.d + 1)))
    n = int(math.ceil((math.pi - top) / step))
    pts += [top + (math.pi - top) * i / n for i in range(1, n + 1)]
    for c in _angles_of(g1.poles, t) + _angles_of(g1.zeros, t):
        pts += [c * (1 + s * 10 ** (-e / 4)) for e in range(0, 40) for s in (-1, 1)]
    if cutoff_angle is not None:
        a, b = 1e-2 * cutoff_angle, min(math.pi, 1e2 * cutoff_angle)
        pts += [a * (b / a) ** (i / 80) for i in range(81)]
    return sorted(p for p in set(pts) if lo <= p <= math.pi)


def reference_critical_force_gain(device: Device, human: Human, filter_order: int | None = None,
                                  cutoff_hz: float | None = None,
                                  digits: int = REFERENCE_DIGITS) -> FeedforwardReference:
    """K_f,cr of 1 + K_f·D(z)·G_1(z) at ``digits`` digits (see module doc); no filter when cutoff_hz is None."""
    if device.delay_samples > REFERENCE_FORCE_GAIN_MAX_DELAY_SAMPLES:
        raise InputError("device.delay", f"the reference rung is capped at {REFERENCE_FORCE_GAIN_MAX_DELAY_SAMPLES} samples of delay "
                         "(its cost grows linearly with the delay)")
    with mp.workdps(digits + _GUARD):
        g1 = _G1(device, human)
        if any(mp.re(p) >= 0 and abs(p) > 0 for p in g1.poles):
            raise InputError("device", "the reference rung needs a damped device and grasp (a pole of G_1 is not "
                             "in the open left half plane)")
        dz = _butterworth(filter_order, cutoff_hz, device.sample_time) if cutoff_hz is not None else None
        count = [0]

        def loop(theta):
            count[0] += 1
            z = mp.expj(theta)
            return g1(z) * dz(z) if dz is not None else g1(z)

        def im_h(theta):
            return -mp.im(mp.conj(loop(theta)))    # Im of h̃ = −conj(D·G_1)

        cutoff_angle = 2 * math.pi * cutoff_hz * device.sample_time if cutoff_hz is not None else None
        pts = _grid(g1, cutoff_angle)
        vals = [-mp.conj(loop(mp.mpf(p))) for p in pts]
        found: list[tuple[float, float]] = []
        for (p0, v0), (p1, v1) in zip(zip(pts, vals), zip(pts[1:], vals[1:])):
            if mp.sign(mp.im(v0)) * mp.sign(mp.im(v1)) < 0 and (mp.re(v0) > 0 or mp.re(v1) > 0):
                root, _ = _bisect(im_h, mp.mpf(p0), mp.mpf(p1), mp.im(v0), digits)
                val = loop(root)
                if mp.re(-mp.conj(val)) > 0 and math.pi - float(root) > 1e-12:
                    found.append((float(root), float(1 / abs(val))))
        if dz is None:
            # the Nyquist point is a crossing when h(π) = −1/G_1(−1) is real and positive (eq. 32)
            v = loop(mp.pi)
            if mp.re(-v) > 0:
                found.append((math.pi, float(1 / abs(v))))
    t = device.sample_time
    cross = tuple((a / t, k) for a, k in found)
    if not cross:
        return FeedforwardReference(math.inf, None, (), digits, count[0])
    w, k = min(cross, key=lambda c: c[1])
    return FeedforwardReference(k, w, cross, digits, count[0])
