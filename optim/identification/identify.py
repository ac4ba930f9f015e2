"""identify(): validate the data, fit the model(s) asked, choose, and state what is known and how well.

``model = "auto"`` fits both structures and chooses by BIC (n·ln(RSS/n) + p·ln n; AIC shown beside it):
the cable model must buy its four extra parameters with a better fit, so a rigid device's data choose
rigid.  A fit that does not converge, or whose Jacobian leaves a parameter undetermined, is ``failed``
with the reason; no device is returned then.
"""

from __future__ import annotations

import math
import time

import numpy as np
from pydantic import ValidationError

from optim.domain import check_device_domain
from optim.errors import InputError
from optim.identification.data import (
    BAND_RATIO,
    FrequencyResponseData,
    TimeSeriesData,
    check_response,
    check_time_series,
    excited_band,
    warnings_for,
)
from optim.identification.fit import FitOutcome, fit_model, refine_friction, refit_first_half
from optim.identification.misspecification import (
    EXACT_FIT,
    PLATEAU_FRACTION,
    WHITENESS_P,
    Misspecification,
    drift,
    long_run_factor,
    plateau,
)
from optim.identification.models import PARAMS, POSITIVE, ModelName
from optim.identification.problem import Problem
from optim.identification.result import Comparison, FitQuality, IdentificationResult, Parameter
from optim.identification.stats import IDENTIFIABLE_RCOND, covariance, information_criteria, ljung_box, nrmse, quantile

__all__ = ["DEFAULT_MAX_DELAY_SAMPLES", "MAX_DELAY_SEARCH_SAMPLES", "identify"]

#: the delay is searched in [0, max_delay]; default 20 samples
DEFAULT_MAX_DELAY_SAMPLES = 20
#: cost limit of the search (one start per whole sample)
MAX_DELAY_SEARCH_SAMPLES = 200


def _check_known(model: str, known: dict[str, float], friction: bool) -> None:
    allowed = set(PARAMS["rigid"]) | set(PARAMS["cable"]) if model != "auto" else {"delay"}
    if model in PARAMS:
        allowed = set(PARAMS[model])
    if friction:
        allowed.add("friction")
    for name, value in known.items():
        if name not in allowed:
            hint = "with model auto only delay (and friction) can be fixed" if model == "auto" else \
                f"the {model} model's parameters are {', '.join(PARAMS[model])}"
            raise InputError(f"known.{name}", f"not a free parameter here ({hint})")
        if not (isinstance(value, (int, float)) and math.isfinite(value)) or value < 0 or \
                (name in POSITIVE and value <= 0):
            raise InputError(f"known.{name}", f"must be finite and {'> 0' if name in POSITIVE else '≥ 0'}")


def _free_count(model: str, known: dict[str, float], friction: bool, ts: bool) -> int:
    phys = sum(1 for p in PARAMS[model] if p not in known)
    return phys + (1 if ts else 0) + (1 if friction and "friction" not in known else 0)


def _whiteness(residual: np.ndarray, fitted: int) -> tuple[dict, tuple[float, ...]]:
    n = len(residual)
    lags = int(max(1, min(20, n // 5)))
    q, p, rho = ljung_box(residual, lags, 0)
    bound = 1.959963984540054 / math.sqrt(n)
    return ({"test": "ljung-box", "lags": lags, "statistic": q, "p_value": p, "white": bool(p >= 0.05),
             "bound": bound, "outside_bound": int(np.sum(np.abs(rho) > bound))},
            tuple(float(v) for v in rho))


def _summary(out: FitOutcome) -> tuple[float, float, float]:
    n = len(out.problem.measured)
    aic, bic = information_criteria(out.rss, n, len(out.problem.names))
    return aic, bic, nrmse(out.problem.residual(out.x), out.problem.measured)


def _finish(out: FitOutcome, confidence: float) -> tuple[IdentificationResult | None, str | None]:
    """The parameters, device and uncertainty of a converged fit, or why it cannot be trusted."""
    prob = out.problem
    cov, _, rcond = covariance(out.jac, out.rss)
    if rcond < IDENTIFIABLE_RCOND:
        _, _, vt = np.linalg.svd(out.jac / np.maximum(np.linalg.norm(out.jac, axis=0), 1e-300))
        weak = [prob.names[i] for i in np.argsort(-np.abs(vt[-1]))[:2]]
        return None, (f"the data do not determine the {out.model} model: its Jacobian is singular "
                      f"(rcond {rcond:.2e}), the direction mixes {' and '.join(weak)}; excite more (e.g. the "
                      f"resonance) or fix a parameter with known")
    dof = len(prob.measured) - len(prob.names)
    z = quantile(confidence, dof)
    params: dict[str, Parameter] = {}
    for i, name in enumerate(prob.names):
        if name == "offset":
            continue
        se = float(math.sqrt(max(cov[i, i], 0.0)))
        v = float(out.x[i])
        params[name] = Parameter(v, se, (max(v - z * se, 0.0), v + z * se))
    for name, v in prob.fixed.items():
        params[name] = Parameter(float(v), 0.0, (float(v), float(v)))
    try:
        dev = prob.device(out.x)
        check_device_domain(dev)
    except (ValidationError, ValueError) as exc:
        return None, f"the fitted {out.model} device is outside the numeric domain ({exc})"
    warns: list[str] = []
    unc: dict[str, dict[str, float]] = {}
    for name in PARAMS[out.model]:
        p = params[name]
        if name in prob.fixed:
            continue
        if name in POSITIVE and not p.value - z * p.std_error > 0:
            return None, (f"the data do not determine {name} of the {out.model} model: its {confidence:g} interval "
                          f"[{p.value - z * p.std_error:.4g}, {p.interval[1]:.4g}] reaches 0")
        unc[f"device.{name}"] = {"min": p.interval[0], "max": p.interval[1]}
    device = dev.model_dump(exclude_none=True, exclude={"preset"})
    return IdentificationResult(status="identified", model=out.model, reason="", device=device,
                                parameters=params, uncertainty=unc, warnings=tuple(warns),
                                confidence=confidence), None


def _fitted_curves(out: FitOutcome) -> dict:
    prob = out.problem
    y = prob.output(out.x)
    if isinstance(prob.data, TimeSeriesData):
        t = np.arange(len(y)) * prob.sample_time
        return {"kind": "time_series", "x": t, "measured": prob.data.position, "fitted": y}
    n = len(prob.data.frequency)
    h = (y[:n] + 1j * y[n:]) / prob._w
    return {"kind": "frequency_response", "x": prob.data.frequency, "measured": prob.data.response, "fitted": h}


def identify(data: TimeSeriesData | FrequencyResponseData, model: str = "auto", known: dict[str, float] | None = None,
             friction: bool = False, confidence: float = 0.95, max_delay: float | None = None) -> IdentificationResult:
    """Identify a device from ``data`` (see the package docstring).  Raises ValueError("field: rule") for
    data or options that cannot be used (the service's 422)."""
    t0 = time.perf_counter()
    known = dict(known or {})
    ts = isinstance(data, TimeSeriesData)
    if model not in ("rigid", "cable", "auto"):
        raise InputError("model", "must be rigid, cable or auto")
    if not 0.5 <= confidence < 1.0:
        raise InputError("confidence", "must be in [0.5, 1)")
    if friction and not ts:
        raise InputError("friction", "the Coulomb term needs a time series (a frequency response is linear)")
    _check_known(model, known, friction)
    for m in (("rigid", "cable") if model == "auto" else (model,)):
        if all(p in known for p in PARAMS[m]):
            raise InputError("known", f"fixes every parameter of the {m} model; nothing is left to identify")
    t = data.sample_time
    if max_delay is None:
        max_delay = known.get("delay", DEFAULT_MAX_DELAY_SAMPLES * t)
    if not (math.isfinite(max_delay) and 0 <= max_delay <= MAX_DELAY_SEARCH_SAMPLES * t):
        raise InputError("max_delay", f"must be in [0, {MAX_DELAY_SEARCH_SAMPLES}·sample_time] "
                         f"(one start per whole sample of delay)")
    asked: tuple[ModelName, ...] = ("rigid", "cable") if model == "auto" else (model,)  # type: ignore[assignment]
    notes: list[str] = []
    if ts:
        if model == "auto":
            check_time_series(data, _free_count("rigid", known, friction, ts), ("rigid",))
            f5, f95 = excited_band(data.force, t)
            if not f95 / f5 >= BAND_RATIO["cable"]:
                asked = ("rigid",)
                notes.append(f"the cable model was not fitted: the input's band {f5:.3g}-{f95:.3g} Hz is too "
                             f"narrow for it (ratio below {BAND_RATIO['cable']:g})")
        check_time_series(data, max(_free_count(m, known, friction, ts) for m in asked), asked)
    else:
        check_response(data, max(_free_count(m, known, friction, ts) for m in asked))
    warnings = warnings_for(data)

    fric_known = {"friction": known["friction"]} if "friction" in known else {}
    rigid_known = {k: v for k, v in known.items() if k in PARAMS["rigid"]} | fric_known
    rigid = fit_model(Problem("rigid", data, rigid_known, friction), max_delay)
    if friction:
        rigid = refine_friction(rigid, max_delay)
    outcomes: dict[str, FitOutcome] = {"rigid": rigid}
    if "cable" in asked:
        cable_known = {k: v for k, v in known.items() if k in PARAMS["cable"]} | fric_known
        if rigid.last is None:
            outcomes["cable"] = FitOutcome("cable", Problem("cable", data, cable_known, friction), None, math.inf,
                                           None, 0, f"no rigid fit to start from ({rigid.reason})")
        else:   # a rigid fit that did not converge still gives the mass scale and the delay to start from
            outcomes["cable"] = fit_model(Problem("cable", data, cable_known, friction), max_delay,
                                          rigid.problem.values(rigid.last))
            if friction:
                outcomes["cable"] = refine_friction(outcomes["cable"], max_delay)
    finished: dict[str, tuple[IdentificationResult | None, str | None]] = {}
    comparison = []
    compared = ("rigid", "cable") if "cable" in asked else asked     # the cable fit always has its rigid one
    for m in compared:
        out = outcomes[m]
        if out.x is None:
            finished[m] = (None, out.reason)
            comparison.append(Comparison(m, None, None, None, "failed", out.reason))
            continue
        finished[m] = _finish(out, confidence)
        aic, bic, nr = _summary(out)
        res, why = finished[m]
        comparison.append(Comparison(m, aic, bic, nr, "identified" if res else "failed", why))
    chosen, reason = _choose(model, comparison, finished)
    elapsed = 1e3 * (time.perf_counter() - t0)
    if chosen is None:
        return IdentificationResult(status="failed", model=None if model == "auto" else model, reason=reason,
                                    comparison=tuple(comparison), warnings=tuple(warnings), confidence=confidence,
                                    elapsed_ms=elapsed)
    out = outcomes[chosen]
    res = finished[chosen][0]
    assert res is not None and out.x is not None    # _choose picks only a converged, identified fit
    r = out.problem.residual(out.x)
    white, rho = _whiteness(r, len(out.problem.names))
    fit = FitQuality(nrmse=nrmse(r, out.problem.measured), rmse=float(np.sqrt(np.mean(r ** 2))),
                     residual_whiteness=white, residual_autocorrelation=rho, samples=len(r),
                     evaluations=sum(o.problem.evaluations for o in outcomes.values()),
                     starts=sum(o.starts for o in outcomes.values()))
    by = {c.model: c for c in comparison}
    if chosen == "cable" and model == "cable" and by["rigid"].bic is not None and by["rigid"].bic < by["cable"].bic:
        warnings.append(f"model: the rigid model explains these data better (BIC lower by "
                        f"{by['cable'].bic - by['rigid'].bic:.4g}): the cable mode found here is not supported by "
                        f"the data; use model auto")
    dl = res.parameters["delay"]
    if "delay" not in known and dl.value >= max_delay - 1e-9 * t:
        warnings.append(f"parameters.delay: {dl.value:.6g} s is at the edge of the searched range [0, max_delay = "
                        f"{max_delay:.6g} s]: the model is probably wrong for this data (friction? the cable mode?) "
                        f"or the delay is longer (raise max_delay)")
    mis = _misspecification(out, res, white, rho, max_delay)
    params, unc = res.parameters, res.uncertainty
    if mis.flagged:
        params = _widened(out, res, mis)
        unc = {}
        warnings.append("misspecification: " + "; ".join(mis.reasons) + f". The {chosen} model does not explain "
                        f"these data: the intervals are widened (residual long-run variance factor "
                        f"{mis.variance_factor:.3g}, and to hold the first half's estimates) but a model error "
                        f"biases the values themselves, which no width computed from this fit covers; the "
                        f"uncertainty box is withdrawn. Check the model (cable mode, delay, friction), the force "
                        f"log (saturation) and the sensor (drift)")
    elif not white["white"]:
        warnings.append(f"fit: the residual is not white (Ljung–Box p = {white['p_value']:.2g}): the model misses "
                        f"something in the data (friction, a mode, nonlinearity) or the noise is coloured; the "
                        f"intervals assume white noise")
    return IdentificationResult(
        status="identified_with_warnings" if mis.flagged else "identified", model=chosen,
        reason=" ".join([reason] + notes), device=res.device,
        parameters=params, uncertainty=unc, fit=fit, comparison=tuple(comparison),
        warnings=tuple(warnings) + res.warnings, confidence=confidence, fitted=_fitted_curves(out),
        elapsed_ms=1e3 * (time.perf_counter() - t0))


def _misspecification(out: FitOutcome, res: IdentificationResult, white: dict, rho, max_delay: float) -> Misspecification:
    """The tests of optim.identification.misspecification on the chosen fit."""
    reasons = []
    r = out.problem.residual(out.x)
    measured = out.problem.measured
    # a residual at the rounding level of the data (exact records) has no noise to be white: not a misfit
    rounding = float(np.sqrt(np.mean(r ** 2))) <= EXACT_FIT * float(np.std(measured))
    if white["p_value"] < WHITENESS_P and not rounding:
        reasons.append(f"the residual is far from white (Ljung–Box Q = {white['statistic']:.4g} over "
                       f"{white['lags']} lags, p = {white['p_value']:.2g} < {WHITENESS_P:g})")
    data = out.problem.data
    if isinstance(data, TimeSeriesData):
        flat = plateau(data.force)
        if flat > PLATEAU_FRACTION:
            reasons.append(f"the logged force sits at its extreme ±{np.max(np.abs(data.force)):.6g} N in "
                           f"{100 * flat:.3g} % of the samples: a saturated actuator (the model is linear)")
    half_values: dict[str, float] = {}
    half = None if rounding else refit_first_half(out, max_delay)
    if half is not None:
        half_values, half_se = half
        whole = {n: p.value for n, p in res.parameters.items()}
        whole_se = {n: p.std_error for n, p in res.parameters.items()}
        moved = drift([n for n in out.problem.names if n != "offset"], whole, whole_se, half_values, half_se)
        if moved:
            reasons.append("the first half of the record gives other parameters than the whole: " + ", ".join(moved))
    return Misspecification(tuple(reasons), long_run_factor(np.asarray(rho)), half_values)


def _widened(out: FitOutcome, res: IdentificationResult, mis: Misspecification) -> dict[str, Parameter]:
    """Intervals × √F about the value, stretched to hold the first half's estimate (module misspecification)."""
    f = math.sqrt(mis.variance_factor)
    params: dict[str, Parameter] = {}
    for name, p in res.parameters.items():
        if name in out.problem.fixed:
            params[name] = p
            continue
        lo, hi = p.value - f * (p.value - p.interval[0]), p.value + f * (p.interval[1] - p.value)
        if name in mis.half_values:
            lo, hi = min(lo, mis.half_values[name]), max(hi, mis.half_values[name])
        params[name] = Parameter(p.value, p.std_error * f, (max(lo, 0.0), hi))
    return params


def _choose(model: str, comparison: list[Comparison], finished) -> tuple[str | None, str]:
    by = {c.model: c for c in comparison}
    if model != "auto":
        res, why = finished[model]
        if res is None:
            return None, f"the {model} fit failed: {why}"
        return model, f"the {model} model was asked for"
    ok = [c for c in comparison if c.status == "identified"]
    if not ok:
        return None, "both fits failed: " + "; ".join(f"{c.model}: {c.reason}" for c in comparison)
    if len(ok) == 1:
        other = [c for c in comparison if c.status != "identified"]
        why = f" ({other[0].model}: {other[0].reason})" if other else ""
        return ok[0].model, f"only the {ok[0].model} fit succeeded{why}"
    r, c = by["rigid"], by["cable"]
    d_bic, d_aic = r.bic - c.bic, r.aic - c.aic
    if d_bic > 0:
        return "cable", (f"cable: its BIC is lower by {d_bic:.4g} (AIC by {d_aic:.4g}); the cable mode matters for "
                         f"this data (NRMSE {c.nrmse:.3g} against the rigid model's {r.nrmse:.3g})")
    return "rigid", (f"rigid: the cable model's four extra parameters do not pay for themselves (BIC higher by "
                     f"{-d_bic:.4g}, AIC by {-d_aic:.4g}; NRMSE {c.nrmse:.3g} against {r.nrmse:.3g}); the cable "
                     f"mode does not matter for this data")
