"""Design-space studies: a sweep over dotted device/requirement paths, the points it spans, and
the problem functions evaluated at each point (issue 8).  Pure functions on plain data, no I/O:
the store, the runner and the executors live in ``service/studies``.

A study is ``problem`` + ``base = {device, requirements}`` + ``sweep``; ``sweep`` maps a dotted
path (``device.delay``, ``device.cable.stiffness``, ``requirements.damping`` …) to a value list
or a range ``{start, stop, num, scale}``.  ``sampling`` chooses the Cartesian grid (default) or
a Latin hypercube (scipy.stats.qmc) of ``samples`` points with a ``seed``.

Points are plain numbers so that they pickle to any worker (Dask may run a task twice:
evaluation is a pure function and never writes).  A point is named by its place in the plan (``index``)
and its swept values; the service names a chunk of consecutive points by the content hash of their places
and swept values (service.studies.blocks.block_hash, the one hash of the studies), so that a restarted
study skips what is stored.  Nothing here hashes: the base is fixed by the study's stored request.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import importlib
import math
import types
import typing
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Sequence

import numpy as np
from pydantic import BaseModel, ValidationError

from models.device import MAX_DELAY_SAMPLES, Device, with_delay
from optim.errors import InputError, from_validation
from optim.solver_info import plain

__all__ = ["MAX_STUDY_POINTS", "PROBLEMS", "StudyInputError", "ProblemUnavailable", "Axis", "StudyPlan",
           "Problem", "get_problem", "plan_study", "device_paths", "evaluate_point", "evaluate_chunk",
           "point_builder", "reuses_base"]

#: Cost limit: the largest number of points one study may have (grid product or LHS samples).
MAX_STUDY_POINTS = 1_000_000
PROBLEMS: tuple[str, ...] = ("stability", "critical_stiffness", "stiffness", "inertia", "workspace_critical_stiffness")
#: chunk_factor of the vectorised problems (the service's default chunk of 64 points becomes 16384, the largest chunk:
#: the runner sizes chunks to take about CHUNK_SECONDS, so a rigid critical_stiffness chunk at ~300k points per
#: CPU-s takes ~50 ms and its task, transfer and store write are a few % of it; issue 20)
VECTOR_CHUNK_FACTOR = 256
SCALES = ("linear", "log")
DESIGNS = ("grid", "latin_hypercube")


class StudyInputError(InputError):
    """A study request the planner rejects; ``field`` is the dotted location of the bad input."""

    @property
    def msg(self) -> str:
        return self.rule


class ProblemUnavailable(StudyInputError):
    """The problem's design module is not part of this build (never replaced by a fake result)."""

    def __init__(self, name: str, why: str):
        super().__init__("problem", f"problem {name!r} is not available in this build ({why})")


# ---------------------------------------------------------------------------------------- problems

@dataclass(frozen=True)
class Problem:
    name: str
    evaluate: Callable[[Device, Mapping[str, Any]], dict[str, Any]]
    """(device, requirements) -> flat dict of scalars (floats finite or None, bools, strings)."""
    requirement_kinds: Mapping[str, str]
    """sweepable requirement fields -> "float" | "int"."""
    check_requirements: Callable[[Mapping[str, Any]], None]
    """raises ValueError("<field>: <rule>") for requirements the problem cannot take."""
    evaluate_batch: Callable[[Sequence[Device], Sequence[Mapping[str, Any]]], list[tuple[dict | None, str | None]]] | None = None
    """Optional: a whole chunk at once (valid devices and requirements) -> (results, None) | (None, reason) each."""
    chunk_factor: int = 1
    """Points per chunk relative to the runner's chunk size: a vectorised problem spreads its per-call numpy
    overhead over a larger chunk (the stability problem: ~3600 points/CPU-s at 32 points, ~5200 at 256)."""


def _clean(value: Any) -> Any:
    """A JSON-safe scalar: non-finite floats become None (the row's ``reason`` says why)."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    return value


# Wall-clock fields make two runs of the same point differ; a study stores what the point *is*.
_VOLATILE = ("elapsed_ms", "setup_ms", "solve_ms", "time", "t_wall", "t_proc_total")


def flatten_result(result: Any) -> dict[str, Any]:
    """Scalar fields of a result dataclass (dicts one level deep as ``a.b``), without timings."""
    out: dict[str, Any] = {}
    items = plain(result).items() if dataclasses.is_dataclass(result) else dict(result).items()
    for key, value in items:
        if key in _VOLATILE or key.endswith("_ms") or key.startswith("t_"):
            continue
        if isinstance(value, dict):
            for sub, v in value.items():
                if sub in _VOLATILE or str(sub).endswith("_ms") or str(sub).startswith("t_"):
                    continue
                if v is None or isinstance(v, (bool, int, float, str, np.generic)):
                    out[f"{key}.{sub}"] = _clean(v)
        elif isinstance(value, (list, tuple)):
            if all(isinstance(v, str) for v in value):
                out[key] = ";".join(value)
            elif 0 < len(value) <= 4 and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
                out.update({f"{key}.{i}": _clean(v) for i, v in enumerate(value)})  # a band, a pair
            else:
                out[f"n_{key}"] = len(value)
        elif value is None or isinstance(value, (bool, int, float, str, np.generic)):
            out[key] = _clean(value)
    return out


_STABILITY_REQUIREMENTS = {"stiffness": "float", "damping": "float"}


def _is_finite_number(value: Any) -> bool:
    """A JSON number that is a finite double (an integer of 400 digits is not: float() overflows)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:
        return False


def _check_stability_requirements(req: Mapping[str, Any]) -> None:
    for key, value in req.items():
        if key == "controller":                # the rendered wall (plan_study's ``controller``)
            from optim.studies.rendered_study import check_controller
            check_controller(value)
            continue
        if key not in _STABILITY_REQUIREMENTS:
            raise InputError(key, f"unknown requirement of the stability problem "
                             f"(known: {', '.join(_STABILITY_REQUIREMENTS)})")
        if value is None:
            continue
        if not _is_finite_number(value):
            raise InputError(key, "must be a finite number")
    k, b = req.get("stiffness"), req.get("damping")
    if k is not None and not k > 0:
        raise InputError("stiffness", "the wall's K must be > 0 [N/m]")
    if b is not None and not b >= 0:
        raise InputError("damping", "the wall's B must be ≥ 0 [N·s/m]")


def _requirement_kinds(cls: type[BaseModel]) -> dict[str, str]:
    """Numeric fields of a requirements model: the ones a sweep may set."""
    kinds = {}
    for name, info in cls.model_fields.items():
        args = set(typing.get_args(info.annotation)) or {info.annotation}
        args.discard(type(None))
        if args == {float} or args == {int, float}:
            kinds[name] = "float"
        elif args == {int}:
            kinds[name] = "int"
    return kinds


def _design_problem(name: str, module: str, function: str, requirements: str) -> Problem:
    """A design problem of another module, imported only when asked for (None in the registry if absent)."""
    try:
        mod = importlib.import_module(module)
        design = getattr(mod, function)
        req_cls = getattr(mod, requirements, None) or getattr(importlib.import_module(design.__module__),
                                                              requirements)
    except (ImportError, AttributeError) as exc:
        raise ProblemUnavailable(name, f"{module}.{function} cannot be imported: {exc}") from None
    field_names = set(req_cls.model_fields)

    def build(req: Mapping[str, Any]):
        unknown = sorted(set(req) - field_names)
        if unknown:
            raise InputError(unknown[0], f"unknown requirement of the {name} problem "
                             f"(known: {', '.join(sorted(field_names))})")
        kinds = _requirement_kinds(req_cls)
        for key, value in req.items():
            # A number is a JSON number: true and "5.4" are refused, not taken as 1 and 5.4.
            if key in kinds and value is not None and not _is_finite_number(value):
                raise InputError(key, f"must be a finite number, got {str(value)[:40]!r}")
        try:
            return req_cls.model_validate(req)
        except ValidationError as exc:  # the model's own rule and message (one source)
            raise from_validation(exc) from None

    def evaluate(device: Device, req: Mapping[str, Any]) -> dict[str, Any]:
        return flatten_result(design(device, build(req)))

    return Problem(name, evaluate, _requirement_kinds(req_cls), lambda req: build(req) and None)


_LAZY = {"stiffness": ("optim.stiffness", "design_stiffness", "StiffnessRequirements"),
         "inertia": ("optim.transparency.inertia", "design_inertia", "InertiaRequirements")}
_CACHE: dict[str, Problem] = {}


def get_problem(name: str) -> Problem:
    """The registered problem; ``ProblemUnavailable`` when its design module is not in this build."""
    if name in _CACHE:
        return _CACHE[name]
    if name in ("stability", "critical_stiffness"):
        # both vectorised over a chunk: the full exact analysis (optim.studies.stability_study) or K_cr(B) alone
        mod = importlib.import_module(".stability_study" if name == "stability" else ".critical_study", __package__)

        def one(device: Device, req: Mapping[str, Any]) -> dict[str, Any]:
            _check_stability_requirements(req)
            return mod.evaluate_one(device, req)

        problem = Problem(name, one, _STABILITY_REQUIREMENTS, _check_stability_requirements, mod.evaluate_batch,
                          chunk_factor=VECTOR_CHUNK_FACTOR)
    elif name == "workspace_critical_stiffness":     # poses swept as requirements.joint_i (optim.studies.workspace_study)
        ws = importlib.import_module(".workspace_study", __package__)
        problem = Problem(name, ws.evaluate_one, ws.REQUIREMENT_KINDS, ws.check_requirements)
    elif name in _LAZY:
        problem = _design_problem(name, *_LAZY[name])
    else:
        raise StudyInputError("problem", f"unknown problem {name!r}; known: {', '.join(PROBLEMS)}")
    _CACHE[name] = problem  # safe across processes: each builds its own
    return problem


# ------------------------------------------------------------------------------------------ sweeps

def _model_paths(model: type, prefix: str) -> dict[str, str]:
    paths: dict[str, str] = {}
    for name, info in model.model_fields.items():
        ann = info.annotation
        args = set(typing.get_args(ann)) if isinstance(ann, types.UnionType) or typing.get_origin(ann) else {ann}
        args.discard(type(None))
        if args == {float}:
            paths[f"{prefix}.{name}"] = "float"
        elif len(args) == 1 and isinstance(next(iter(args)), type) and hasattr(next(iter(args)), "model_fields"):
            paths.update(_model_paths(next(iter(args)), f"{prefix}.{name}"))
    return paths


def device_paths() -> dict[str, str]:
    """Every numeric device field a sweep may set (``device.mass`` … ``device.force_sensor.time_constant``)."""
    return _model_paths(Device, "device")


@dataclass(frozen=True)
class Axis:
    """One swept parameter: explicit values (grid) or a range a Latin hypercube samples."""

    path: str
    kind: str
    values: tuple[float, ...] | None
    start: float | None = None
    stop: float | None = None
    scale: str = "linear"

    def at(self, u: np.ndarray) -> np.ndarray:
        """Map LHS coordinates u ∈ [0, 1) to this axis (a list axis picks among its values)."""
        if self.values is not None:
            vals = np.asarray(self.values, dtype=float)
            return vals[np.minimum((u * len(vals)).astype(np.int64), len(vals) - 1)]
        if self.scale == "log":
            return np.exp(math.log(self.start) + u * (math.log(self.stop) - math.log(self.start)))
        return self.start + u * (self.stop - self.start)


def _number(field: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise StudyInputError(field, f"must be a number, got {value!r}")
    if not _is_finite_number(value):
        raise StudyInputError(field, "must be finite")
    return float(value)


def _axis(path: str, kind: str, spec: Any, design: str) -> Axis:
    field = f"sweep.{path}"
    if isinstance(spec, (list, tuple)):
        if not spec:
            raise StudyInputError(field, "the value list is empty")
        if len(spec) > MAX_STUDY_POINTS:
            raise StudyInputError(field, f"more than {MAX_STUDY_POINTS} values")
        values = tuple(_number(f"{field}.{i}", v) for i, v in enumerate(spec))
    elif isinstance(spec, Mapping):
        unknown = sorted(set(spec) - {"start", "stop", "num", "scale"})
        if unknown:
            raise StudyInputError(f"{field}.{unknown[0]}", "unknown key (a range has start, stop, num, scale)")
        for key in ("start", "stop"):
            if key not in spec:
                raise StudyInputError(f"{field}.{key}", "a range needs start and stop")
        start, stop = _number(f"{field}.start", spec["start"]), _number(f"{field}.stop", spec["stop"])
        scale = spec.get("scale", "linear")
        if scale not in SCALES:
            raise StudyInputError(f"{field}.scale", f"must be one of {', '.join(SCALES)}, got {scale!r}")
        if scale == "log" and not (start > 0 and stop > 0):
            raise StudyInputError(f"{field}.start", "a log range needs start > 0 and stop > 0")
        num = spec.get("num")
        if design == "latin_hypercube" and num is None:
            if kind == "int":
                raise StudyInputError(f"{field}.num", "an integer parameter needs num (or a value list)")
            return Axis(path, kind, None, start, stop, scale)
        if isinstance(num, bool) or not isinstance(num, int) or not 1 <= num <= MAX_STUDY_POINTS:
            raise StudyInputError(f"{field}.num", f"must be an integer from 1 to {MAX_STUDY_POINTS}")
        with np.errstate(over="ignore", invalid="ignore"):  # a range across ±1.8e308 overflows its step
            grid = np.geomspace(start, stop, num) if scale == "log" else np.linspace(start, stop, num)
        if not np.all(np.isfinite(grid)):
            raise StudyInputError(field, "the range's values overflow double precision")
        values = tuple(float(v) for v in grid)
    else:
        raise StudyInputError(field, "must be a list of values or a range {start, stop, num, scale}")
    if kind == "int":
        if any(v != round(v) for v in values):
            raise StudyInputError(field, "this parameter takes whole numbers")
        values = tuple(float(round(v)) for v in values)
    return Axis(path, kind, values)


def _set(tree: dict, path: str, value: Any) -> None:
    keys = _keys(path)
    node = tree
    for key in keys[:-1]:
        child = node.get(key)
        if not isinstance(child, dict):
            child = {}
            node[key] = child
        node = child
    node[keys[-1]] = value


@dataclass(frozen=True)
class StudyPlan:
    """What a study computes: every point, in a fixed order, reproducible from the request alone."""

    problem: str
    device: Mapping[str, Any]
    requirements: Mapping[str, Any]
    axes: tuple[Axis, ...]
    design: str
    samples: int | None
    seed: int | None

    @property
    def paths(self) -> list[str]:
        return [a.path for a in self.axes]

    @property
    def total(self) -> int:
        if self.design == "latin_hypercube":
            return int(self.samples)
        return math.prod(len(a.values) for a in self.axes)

    def values(self, start: int, stop: int) -> np.ndarray:
        """Swept values of points start..stop-1, shape (n, len(axes)); grid order is row-major."""
        idx = np.arange(start, min(stop, self.total), dtype=np.int64)
        if not self.axes:
            return np.zeros((len(idx), 0))
        if self.design == "latin_hypercube":
            u = self._lhs()[idx]
            return np.column_stack([a.at(u[:, j]) for j, a in enumerate(self.axes)])
        shape = tuple(len(a.values) for a in self.axes)
        sub = np.unravel_index(idx, shape)
        return np.column_stack([v[s] for v, s in zip(self._axis_values, sub)])

    @functools.cached_property
    def _axis_values(self) -> list[np.ndarray]:
        """Each grid axis's values as an array, made once (a block of points no longer converts a long axis)."""
        return [np.asarray(a.values, dtype=float) for a in self.axes]

    def _lhs(self) -> np.ndarray:
        cached = _LHS_CACHE.get(self._lhs_key())
        if cached is None:
            from scipy.stats import qmc
            cached = qmc.LatinHypercube(d=len(self.axes), seed=self.seed).random(self.samples)
            _LHS_CACHE.clear()  # one study's sample at a time: bounded memory
            _LHS_CACHE[self._lhs_key()] = cached
        return cached

    def _lhs_key(self) -> tuple:
        return (len(self.axes), self.samples, self.seed)

    def inputs(self, values: Sequence[float]) -> tuple[dict, dict]:
        """(device dict, requirements dict) of one point."""
        return point_builder(self.device, self.requirements, [(a.path, a.kind) for a in self.axes])(values)


_LHS_CACHE: dict[tuple, np.ndarray] = {}


def _keys(path: str) -> list[str]:
    """The keys of a swept path in the point's tree: ``controller.…`` lives in the requirements (plan_study)."""
    keys = path.split(".")
    return ["requirements", *keys] if keys[0] == "controller" else keys


def point_builder(device: Mapping[str, Any], requirements: Mapping[str, Any], axes: Sequence[tuple[str, str]]
                  ) -> Callable[[Sequence[float]], tuple[dict, dict]]:
    """values -> (device dict, requirements dict) of one point, without a deep copy per point.

    The base is deep-copied once; each point gets fresh dicts only along its swept paths and shares
    every other (never mutated) branch with the base: the device validator copies what it changes."""
    base = {"device": copy.deepcopy(dict(device)), "requirements": copy.deepcopy(dict(requirements))}
    steps = [(_keys(path), kind == "int") for path, kind in axes]

    def build(values: Sequence[float]) -> tuple[dict, dict]:
        tree = {"device": dict(base["device"]), "requirements": dict(base["requirements"])}
        fresh = {id(tree["device"]), id(tree["requirements"])}
        for (keys, is_int), v in zip(steps, values):
            node = tree
            for key in keys[:-1]:
                child = node.get(key)
                if not isinstance(child, dict):
                    child = {}
                elif id(child) not in fresh:
                    child = dict(child)
                if id(child) not in fresh:
                    fresh.add(id(child))
                    node[key] = child
                node = child
            node[keys[-1]] = int(v) if is_int else float(v)
        return tree["device"], tree["requirements"]

    return build


def plan_study(problem: str, device: Mapping[str, Any], requirements: Mapping[str, Any] | None,
               sweep: Mapping[str, Any], sampling: Mapping[str, Any] | None = None,
               max_points: int = MAX_STUDY_POINTS, controller: Mapping[str, Any] | None = None) -> StudyPlan:
    """Validate a study request and plan its points; ``StudyInputError`` names the bad field.

    ``max_points`` bounds the study's total (grid product or samples; a deployment may raise it, each axis
    stays within MAX_STUDY_POINTS values).  ``controller``: the wall's rendering {mass?, velocity_filter?}
    (the stability problems only), kept in the requirements as ``controller`` (optim.studies.rendered_study)."""
    from optim.studies.rendered_study import CONTROLLER_PATHS, RENDERED_PROBLEMS
    prob = get_problem(problem)
    requirements = dict(requirements or {})
    if "controller" in requirements:
        raise StudyInputError("base.requirements.controller", "the controller is base.controller")
    rendered = problem in RENDERED_PROBLEMS
    if controller is not None:
        if not rendered:
            raise StudyInputError("base.controller", f"only the {' and '.join(RENDERED_PROBLEMS)} problems take a "
                                                     "controller (a design's filter is its requirements')")
        requirements["controller"] = copy.deepcopy(controller) if isinstance(controller, Mapping) else controller
    elif rendered and any(str(p).startswith("controller.") for p in (sweep if isinstance(sweep, Mapping) else ())):
        requirements["controller"] = {}
    sampling = dict(sampling or {})
    design = sampling.get("design", "grid")
    if design not in DESIGNS:
        raise StudyInputError("sampling.design", f"must be one of {', '.join(DESIGNS)}, got {design!r}")
    samples, seed = sampling.get("samples"), sampling.get("seed")
    if design == "latin_hypercube":
        if isinstance(samples, bool) or not isinstance(samples, int) or samples < 1:
            raise StudyInputError("sampling.samples", "a Latin hypercube needs samples, an integer ≥ 1")
        if samples > max_points:
            raise StudyInputError("sweep", f"{samples} samples exceed the maximum of {max_points} points per study")
        if seed is None or isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2**63:
            raise StudyInputError("sampling.seed", "a Latin hypercube needs a seed, an integer in [0, 2^63)")
    elif samples is not None or seed is not None:
        raise StudyInputError("sampling.samples" if samples is not None else "sampling.seed",
                              "applies only to design latin_hypercube")
    if not isinstance(sweep, Mapping) or not sweep:
        raise StudyInputError("sweep", "must map at least one dotted parameter path to values")
    dev_paths = device_paths()
    axes = []
    for path, spec in sweep.items():
        if path in dev_paths:
            kind = dev_paths[path]
        elif rendered and path in CONTROLLER_PATHS:
            kind = CONTROLLER_PATHS[path]
        elif path.startswith("requirements.") and path.removeprefix("requirements.") in prob.requirement_kinds:
            kind = prob.requirement_kinds[path.removeprefix("requirements.")]
        else:
            known = (sorted(dev_paths) + [f"requirements.{k}" for k in prob.requirement_kinds]
                     + (list(CONTROLLER_PATHS) if rendered else []))
            raise StudyInputError(f"sweep.{path}", f"unknown parameter path; known: {', '.join(known)}")
        axes.append(_axis(path, kind, spec, design))
    if design == "grid":
        total = math.prod(len(a.values) for a in axes)
        if total > max_points:
            raise StudyInputError("sweep", f"the grid has {total} points; the maximum is {max_points} per study")
    plan = StudyPlan(problem, dict(device), requirements, tuple(axes), design, samples, seed)
    _check_base_and_extremes(plan, prob)
    return plan


_NONLINEAR_FIELDS = ("encoder_resolution", "coulomb_friction")


def _check_base_and_extremes(plan: StudyPlan, prob: Problem) -> None:
    """The base must be valid, and so must each axis's extreme values applied alone to it."""
    try:
        # strict: a number must be a JSON number (true and "5.4" are not 1 and 5.4), as in every request body.
        Device.model_validate(dict(plan.device), strict=True)
    except ValueError as exc:
        field, rule = _first_error_at(exc)
        raise StudyInputError(f"base.device.{field}" if field else "base.device", rule) from None
    # the studies' problems analyse the linear loop only: an encoder or a friction would be silently ignored
    for name in _NONLINEAR_FIELDS:
        swept = any(a.path == f"device.{name}" for a in plan.axes)
        if plan.device.get(name) is not None or swept:
            raise StudyInputError(f"sweep.device.{name}" if swept else f"base.device.{name}",
                                  "studies do not analyse encoder quantisation or Coulomb friction (issue 31): "
                                  "use /v1/analysis/stability")
    try:
        prob.check_requirements(plan.requirements)
        _check_rendering(plan.device, plan.requirements)
    except InputError as exc:
        where = "base" if exc.field.startswith("controller") else "base.requirements"
        raise StudyInputError(f"{where}.{exc.field}", exc.rule) from None
    except ValueError as exc:
        raise StudyInputError("base.requirements", str(exc)) from None
    for axis in plan.axes:
        ends = (min(axis.values), max(axis.values)) if axis.values is not None else (axis.start, axis.stop)
        for v in ends:
            tree = {"device": copy.deepcopy(dict(plan.device)), "requirements": dict(plan.requirements)}
            _set(tree, axis.path, int(v) if axis.kind == "int" else float(v))
            try:
                Device.model_validate(tree["device"])
                prob.check_requirements(tree["requirements"])
                _check_rendering(tree["device"], tree["requirements"])
            except ValueError as exc:
                raise StudyInputError(f"sweep.{axis.path}", f"value {v:g}: {_first_error(exc)}") from None


def _check_rendering(device: Mapping[str, Any], requirements: Mapping[str, Any]) -> None:
    """A controller's filter at the device's sample time (a cutoff at or above Nyquist: InputError on its field)."""
    controller = requirements.get("controller")
    if controller:
        from optim.studies.rendered_study import controller_rendering
        controller_rendering(controller, Device.model_validate(dict(device)))


def _first_error_at(exc: ValueError) -> tuple[str, str]:
    """(dotted field, rule) of the first error of a device validation (pydantic's, or an InputError)."""
    errors = getattr(exc, "errors", None)
    if callable(errors):
        e = errors()[0]
        loc = [str(x) for x in e.get("loc", ())]
        cause = (e.get("ctx") or {}).get("error")
        if isinstance(cause, InputError):
            return ".".join([*loc, cause.field]), cause.rule
        return ".".join(loc), e["msg"]
    if isinstance(exc, InputError):
        return exc.field, exc.rule
    return "", str(exc)


def _first_error(exc: ValueError) -> str:
    field, rule = _first_error_at(exc)
    return f"{field}: {rule}" if field else rule


# ------------------------------------------------------------------------------------- evaluation

def evaluate_point(problem: str, device: Mapping[str, Any], requirements: Mapping[str, Any]) -> tuple[dict | None, str | None]:
    """(results, None) or (None, reason) for one point; a point's bad input never stops the study."""
    try:
        dev = Device.model_validate(dict(device))
    except ValueError as exc:
        return None, f"invalid device: {_first_error(exc)}"
    try:
        return get_problem(problem).evaluate(dev, requirements), None
    except Exception as exc:  # noqa: BLE001 - recorded against the point (failed), never dropped
        return None, f"{type(exc).__name__}: {exc}"


def evaluate_chunk(problem: str, device: Mapping[str, Any], requirements: Mapping[str, Any],
                   axes: Sequence[tuple[str, str]], rows: Sequence[tuple[int, Sequence[float]]]) -> list[tuple]:
    """Evaluate points (index, swept values) of one study; returns (index, values, results, error) per point.

    Runs in a worker (local process or Dask): plain data in, plain data out, no writes, so a task
    that runs twice is harmless.  ``axes`` is ((path, kind), …) of the swept values.
    """
    try:
        prob = get_problem(problem)
    except StudyInputError:
        prob = None  # every point records the reason (evaluate_point below)
    if prob is not None and prob.evaluate_batch is not None:
        return _evaluate_chunk_batch(prob, device, requirements, axes, rows)
    out = []
    build = point_builder(device, requirements, axes)
    for index, values in rows:
        dev, req = build(values)
        result, error = evaluate_point(problem, dev, req)
        out.append((index, list(map(float, values)), result, error))
    return out


_UNCHECKED = object()


def reuses_base(delay: Any, sample_time: float) -> bool:
    """A point whose non-delay values a validated device already has takes that device with its own delay
    (models.device.with_delay, nothing validated) where the delay is a plain finite float ≥ 0 within the samples
    limit; any other point is validated whole (and so gets its own error)."""
    return type(delay) is float and 0.0 <= delay < math.inf and delay / sample_time <= MAX_DELAY_SAMPLES


def _evaluate_chunk_batch(prob: Problem, device: Mapping[str, Any], requirements: Mapping[str, Any],
                          axes: Sequence[tuple[str, str]], rows: Sequence[tuple[int, Sequence[float]]]) -> list[tuple]:
    """evaluate_chunk of a vectorised problem: each point validated alone, the valid ones evaluated together."""
    errors: list[str | None] = []
    devices: list[Device] = []
    reqs: list[Mapping[str, Any]] = []
    build = point_builder(device, requirements, axes)
    # the requirements are checked once per distinct set (a grid repeats a few), each point's device alone
    # (the base requirements are the same for every point: the swept requirement values are the key)
    checked: dict[tuple, str | None] = {}
    req_axes = [j for j, (path, _) in enumerate(axes) if path.startswith("requirements.")]
    validate = Device.model_validate
    # A swept delay: the points that differ only in their delay share one validated device, copied with each delay
    # (what validation would give: the delay is a plain float field, and its one rule that involves other fields,
    # the samples limit, is checked here with the sample time; any other delay is validated whole, so its error
    # reads as validation's)
    delay_axis = next((j for j, (path, _) in enumerate(axes) if path == "device.delay"), None)
    others = [j for j in range(len(axes)) if j != delay_axis]
    by_rest: dict[tuple, Device] = {}
    # no swept requirement (nor controller value): every point's requirements are the base's, one dict for all (the
    # problems read it, never change it); a point's device dict is built only where its device is validated
    fixed_req = None
    if rows and not any(path.startswith(("requirements.", "controller.")) for path, _ in axes):
        fixed_req = build(rows[0][1])[1]
    for _, values in rows:
        dev_in, req = build(values) if fixed_req is None else (None, fixed_req)
        try:
            dev = None
            if delay_axis is not None:
                delay = values[delay_axis]
                rest = tuple([values[j] for j in others])
                known = by_rest.get(rest)
                if known is not None and reuses_base(delay, known.sample_time):
                    dev = with_delay(known, delay)
            if dev is None:
                dev = validate(build(values)[0] if dev_in is None else dev_in)
                if delay_axis is not None:
                    by_rest.setdefault(rest, dev)
        except ValueError as exc:
            errors.append(f"invalid device: {_first_error(exc)}")
            continue
        key = tuple([values[j] for j in req_axes])
        bad = checked.get(key, _UNCHECKED)
        if bad is _UNCHECKED:
            try:
                prob.check_requirements(req)
                bad = None
            except ValueError as exc:
                bad = f"ValueError: {exc}"
            checked[key] = bad
        if bad is not None:
            errors.append(bad)
            continue
        errors.append(None)
        devices.append(dev)
        reqs.append(req)
    results = iter(prob.evaluate_batch(devices, reqs))
    out = []
    for (index, values), error in zip(rows, errors):
        result = None
        if error is None:
            result, error = next(results)
        out.append((index, list(map(float, values)), result, error))
    return out
