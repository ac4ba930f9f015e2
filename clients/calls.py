"""One builder per endpoint: what to send and how to read the answer, shared by the sync and async clients.

A builder is a pure function of the caller's arguments that returns a :class:`Call`
(method, path, JSON body, the kind of call that picks its timeout, and the parser
of a successful answer).  The clients only send calls; nothing here touches the
network, so the request a method sends can be inspected (``calls.stability(...)``)
and tested without a server.

Answers are read into the client's own response models (:mod:`clients.schemas`, held
against the server's /openapi.json by a test), so the client imports neither the
server nor the numerics, and a field renamed on one side fails loudly.  Arguments that are left
``None`` are not sent: the server's defaults apply, as they do for ``curl``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from typing import Any, Generic, Literal, Protocol, TypeVar, runtime_checkable

import httpx
from pydantic import BaseModel, TypeAdapter

from .schemas import (
    BoundaryResponse,
    Device,
    ForceFeedforwardResponse,
    HardwareDesignResponse,
    Health,
    IdentifyResponse,
    InertiaResponse,
    SimulateResponse,
    StabilityResponse,
    StiffnessDesignResponse,
    StudyCreated,
    StudyList,
    StudyResults,
    StudyStatus,
    WorkspaceResponse,
)

__all__ = ["Call", "Kind", "Plot", "health", "presets", "stability", "boundary", "force_feedforward",
           "design_stiffness", "design_inertia", "design_hardware", "plot_hardware", "simulate", "plot_simulation",
           "plot_boundary", "plot_bode", "submit_study", "study", "studies", "study_results", "export_study",
           "cancel_study", "plot_study", "plot_robust", "device_json", "Export", "identify", "plot_identify"]

R = TypeVar("R")
#: Kinds of call, each with its own timeout (see :class:`clients.client.Timeouts`).
Kind = Literal["health", "read", "analysis", "design", "simulate", "plot", "submit", "results"]
ImageFormat = Literal["png", "svg"]


@runtime_checkable
class Dumpable(Protocol):
    """Anything pydantic-like: a ``models.device.Device`` built by the caller, or a model of :mod:`clients.schemas`."""

    def model_dump(self, *, mode: str = ..., exclude: Any = ..., exclude_unset: bool = ...) -> dict[str, Any]: ...


DeviceLike = Dumpable | Mapping[str, Any]
PartLike = Dumpable | Mapping[str, Any]


@dataclasses.dataclass(frozen=True)
class Call(Generic[R]):
    """One HTTP request of the contract and the parser of its 2xx answer."""

    method: Literal["GET", "POST", "DELETE"]
    path: str
    kind: Kind
    parse: Callable[[httpx.Response], R]
    json: dict[str, Any] | None = None
    params: dict[str, Any] | None = None


@dataclasses.dataclass(frozen=True)
class Plot:
    """A figure the service drew: its bytes and media type (``image/png`` or ``image/svg+xml``)."""

    content: bytes
    media_type: str

    def save(self, path: str) -> None:
        with open(path, "wb") as fh:
            fh.write(self.content)


def device_json(device: DeviceLike) -> dict[str, Any]:
    """The device object to send.

    A model (anything with pydantic's ``model_dump``: the server's
    ``models.device.Device``, which this module never imports, or a
    :class:`clients.schemas.Device` from :func:`presets`) is sent fully resolved
    without its ``preset`` name (its preset was applied when it was built; sending
    the name again would re-apply the preset's blocks that the model deliberately
    removed, e.g. a ``cable=None`` rigid variant).  A mapping is sent as given and
    validated by the server.
    """
    if not isinstance(device, Mapping) and isinstance(device, Dumpable):
        return device.model_dump(mode="json", exclude={"preset"})
    return dict(device)


def _part(value: PartLike) -> dict[str, Any]:
    if not isinstance(value, Mapping) and isinstance(value, Dumpable):
        return value.model_dump(mode="json", exclude_unset=True)
    return dict(value)


def _body(**fields: Any) -> dict[str, Any]:
    """A request body without the arguments left ``None`` (the server's defaults apply)."""
    out: dict[str, Any] = {}
    for key, value in fields.items():
        if value is None:
            continue
        out[key] = device_json(value) if key == "device" else (
            _part(value) if isinstance(value, (Dumpable, Mapping)) else value)
    return out


def _model(model: type[BaseModel]) -> Callable[[httpx.Response], Any]:
    def parse(response: httpx.Response) -> Any:
        return model.model_validate_json(response.content)
    parse.__qualname__ = f"parse {model.__name__}"
    return parse


def _image(response: httpx.Response) -> Plot:
    return Plot(content=response.content, media_type=response.headers.get("content-type", "").split(";")[0])


def _export(response: httpx.Response) -> Export:
    return Export(**dataclasses.asdict(_image(response)))


_PRESETS = TypeAdapter(dict[str, Device])


def health() -> Call[Health]:
    """``GET /healthz``: liveness and the service's version (open even when /v1 needs a token)."""
    return Call("GET", "/healthz", "health", _model(Health))


def presets() -> Call[dict[str, Device]]:
    """``GET /v1/presets``: the chapter's devices (Table 2, §4.3) as validated :class:`Device` objects."""
    return Call("GET", "/v1/presets", "read", lambda r: _PRESETS.validate_json(r.content))


def stability(device: DeviceLike, controller: PartLike | None = None, *,
              method: Literal["linear", "grid", "exact", "reference"] | None = None,
              grid_points: int | None = None, verify: bool = False) -> Call[StabilityResponse]:
    """``POST /v1/analysis/stability``: K_cr(B) [N/m], every crossover, margin and passivity of a wall.

    ``controller`` is ``{"stiffness": K [N/m], "damping": B [N·s/m]}``, optionally with the rendered wall's
    ``"mass": M [kg]`` and ``"velocity_filter": {"kind": "low_pass", "cutoff_hz": f, "order": 1 | 2}`` (or
    ``moving_average`` with ``samples``, ``transfer_function``; then ``.mass_range`` answers the stable M); without
    it the analysis is at B = 0 and has no margin.  ``method`` is the rung of the
    accuracy ladder (server default ``exact``).  ``verify=True`` adds ``.verification``:
    the closed loop just below and above the answer, checked independently (docs/verification.md).
    """
    return Call("POST", "/v1/analysis/stability", "analysis", _model(StabilityResponse),
                json=_body(device=device, controller=controller, method=method, grid_points=grid_points,
                           verify=verify or None))


def workspace(device: Mapping[str, Any], poses: Mapping[str, Any], normals: list[list[float]] | str = "worst",
              controller: PartLike | None = None) -> Call[WorkspaceResponse]:
    """``POST /v1/analysis/workspace``: K_cr [N/m] of the wall at every pose and normal of a multi-DOF device.

    ``device`` is ``{"sample_time", "delay", "kinematics": {"urdf", "end_effector"} | {"preset"}}``;
    ``poses`` one of ``{"explicit": [[q…]]}``, ``{"grid": {"num": n}}``, ``{"latin_hypercube": {"samples": n,
    "seed": s}}``; ``normals`` unit vectors in the base frame or ``"worst"`` (each pose's worst normal).
    """
    return Call("POST", "/v1/analysis/workspace", "analysis", _model(WorkspaceResponse),
                json=_body(device=device, poses=poses, normals=normals, controller=controller))


def boundary(device: DeviceLike, controller: PartLike | None = None, *, damping_max: float | None = None,
             points: int | None = None, verify: bool = False) -> Call[BoundaryResponse]:
    """``POST /v1/analysis/boundary``: K_cr(B) [N/m] from B = 0 to ``damping_max`` [N·s/m] and its optimum.

    ``controller`` is the rendered wall on the boundary, ``{"mass": M [kg], "velocity_filter": {"kind": "low_pass",
    "cutoff_hz": f, "order": 1}}`` (either optional; default today's wall)."""
    return Call("POST", "/v1/analysis/boundary", "analysis", _model(BoundaryResponse),
                json=_body(device=device, controller=controller, damping_max=damping_max, points=points,
                           verify=verify or None))


def force_feedforward(device: DeviceLike, filter: PartLike | None = None, *,  # noqa: A002
                      verify: bool = False) -> Call[ForceFeedforwardResponse]:
    """``POST /v1/analysis/force-feedforward``: critical force gain K_f,cr (chapter §5, eq. 32-34).

    ``filter`` is the Butterworth D(z), ``{"cutoff_hz": f_c [Hz], "order": n}``.  ``verify=True`` adds
    ``.verification`` (docs/verification.md).
    """
    return Call("POST", "/v1/analysis/force-feedforward", "analysis", _model(ForceFeedforwardResponse),
                json=_body(device=device, filter=filter, verify=verify or None))


def design_stiffness(device: DeviceLike, requirements: PartLike | None = None, *,
                     controller: PartLike | None = None,
                     verify: bool = False) -> Call[StiffnessDesignResponse]:
    """``POST /v1/design/stiffness``: the stiffest safe wall K [N/m] with its damping B [N·s/m].

    ``controller`` is the rendered wall's ``{"mass": M [kg], "velocity_filter": {...}}`` (a fixed filter); a cutoff
    designed with K and B goes in ``requirements["velocity_filter"] = {"kind": "low_pass", "order": 1, "design":
    True, "min_cutoff_hz": …, "max_cutoff_hz": …}``, with ``quantization`` and ``max_force_noise`` and/or
    ``max_force_noise_rms`` [N] (the noise rules that give the cutoff its optimum).  The answer's ``.rendered``
    says which filter and noise it renders.

    ``verify=True`` adds ``.verification``: the margin and passivity checked on the closed loop (a robust design:
    at every corner of its box and its worst device, one verdict each in ``.verification.points``)."""
    return Call("POST", "/v1/design/stiffness", "design", _model(StiffnessDesignResponse),
                json=_body(device=device, requirements=requirements, controller=controller, verify=verify or None))


def design_inertia(device: DeviceLike, requirements: PartLike | None = None, *,
                   verify: bool = False) -> Call[InertiaResponse]:
    """``POST /v1/design/inertia``: force-feedforward gain K_f, filter cutoff [Hz] and apparent mass [kg].

    ``verify=True`` adds ``.verification``: the margin and K_f checked on the closed loop (a robust design: at
    every corner of its box and its worst device, one verdict each in ``.verification.points``)."""
    return Call("POST", "/v1/design/inertia", "design", _model(InertiaResponse),
                json=_body(device=device, requirements=requirements, verify=verify or None))


def _hardware_body(device: DeviceLike, free: str, stiffness: float | None, force_gain: float | None,
                   apparent_mass: float | None, min_gain_margin_db: float | None, max_damping: float | None,
                   cutoff_min_hz: float | None, filter_order: int | None, points: int | None,
                   value_range: tuple[float, float] | None = None) -> dict[str, Any]:
    target = _body(stiffness=stiffness, force_gain=force_gain, apparent_mass=apparent_mass,
                   min_gain_margin_db=min_gain_margin_db, max_damping=max_damping, cutoff_min_hz=cutoff_min_hz,
                   filter_order=filter_order)
    scan = None if value_range is None else {"min": value_range[0], "max": value_range[1]}
    return _body(device=device, target=target, free=free, points=points, range=scan)


def design_hardware(device: DeviceLike, free: str, *, stiffness: float | None = None, force_gain: float | None = None,
                    apparent_mass: float | None = None, min_gain_margin_db: float | None = None,
                    max_damping: float | None = None, cutoff_min_hz: float | None = None,
                    filter_order: int | None = None, points: int | None = None,
                    value_range: tuple[float, float] | None = None,
                    verify: bool = False) -> Call[HardwareDesignResponse]:
    """``POST /v1/design/hardware``: the loosest value of ``free`` (sample_time, delay, damping, mass,
    cable.stiffness) that still renders a wall ``stiffness`` K [N/m] and/or a force-feedforward ``force_gain``
    K_f or ``apparent_mass`` [kg], with the controller and the trade-off curve.  ``value_range`` (min, max)
    scans exactly that range of ``free`` (the request's ``range``); by default the span is widened as needed.
    ``verify=True`` adds ``.verification``: the controller checked on the closed loop at the answer's value."""
    body = _hardware_body(device, free, stiffness, force_gain, apparent_mass, min_gain_margin_db, max_damping,
                          cutoff_min_hz, filter_order, points, value_range)
    if verify:
        body["verify"] = True
    return Call("POST", "/v1/design/hardware", "design", _model(HardwareDesignResponse), json=body)


def plot_robust(device: DeviceLike, requirements: PartLike, *, x: str | None = None, y: str | None = None,
                points: int | None = None, format: ImageFormat = "png") -> Call[Plot]:  # noqa: A002
    """``POST /v1/plots/robust?format=``: the robust stiffness design's margin over a two-parameter slice of the
    box (``requirements.uncertainty``), the worst case marked."""
    return Call("POST", "/v1/plots/robust", "plot", _image,
                json=_body(device=device, requirements=requirements, x=x, y=y, points=points),
                params={"format": format})


def plot_hardware(device: DeviceLike, free: str, *, stiffness: float | None = None, force_gain: float | None = None,
                  apparent_mass: float | None = None, min_gain_margin_db: float | None = None,
                  max_damping: float | None = None, cutoff_min_hz: float | None = None,
                  filter_order: int | None = None, points: int | None = None,
                  format: ImageFormat = "png") -> Call[Plot]:  # noqa: A002
    """``POST /v1/plots/hardware?format=``: the hardware trade-off curves, one panel per target."""
    return Call("POST", "/v1/plots/hardware", "plot", _image,
                json=_hardware_body(device, free, stiffness, force_gain, apparent_mass, min_gain_margin_db,
                                    max_damping, cutoff_min_hz, filter_order, points), params={"format": format})


def _identify_body(data: Mapping[str, Any], model: str | None, known: Mapping[str, float] | None,
                   friction: bool | None, confidence: float | None, sample_time: float | None,
                   max_delay: float | None) -> dict[str, Any]:
    return _body(data=dict(data), model=model, known=dict(known) if known is not None else None, friction=friction,
                 confidence=confidence, sample_time=sample_time, max_delay=max_delay)


def identify(data: Mapping[str, Any], *, model: str | None = None, known: Mapping[str, float] | None = None,
             friction: bool | None = None, confidence: float | None = None, sample_time: float | None = None,
             max_delay: float | None = None) -> Call[IdentifyResponse]:
    """``POST /v1/identify``: a device, its parameters' intervals and the ``uncertainty`` box from measured
    ``data`` ({"kind": "time_series", "sample_time", "force", "position"} or {"kind": "frequency_response",
    "frequency", "real", "imag"}); ``model`` rigid, cable or auto."""
    return Call("POST", "/v1/identify", "design", _model(IdentifyResponse),
                json=_identify_body(data, model, known, friction, confidence, sample_time, max_delay))


def plot_identify(data: Mapping[str, Any], *, model: str | None = None, known: Mapping[str, float] | None = None,
                  friction: bool | None = None, confidence: float | None = None, sample_time: float | None = None,
                  max_delay: float | None = None, format: ImageFormat = "png") -> Call[Plot]:  # noqa: A002
    """``POST /v1/plots/identify?format=``: measured against fitted, with the residual."""
    return Call("POST", "/v1/plots/identify", "plot", _image,
                json=_identify_body(data, model, known, friction, confidence, sample_time, max_delay),
                params={"format": format})


def simulate(device: DeviceLike, scene: PartLike) -> Call[SimulateResponse]:
    """``POST /v1/simulate``: run a scene (release, push or relay) and read its verdict."""
    return Call("POST", "/v1/simulate", "simulate", _model(SimulateResponse), json=_body(device=device, scene=scene))


def plot_simulation(device: DeviceLike, scene: PartLike, *, format: ImageFormat = "png") -> Call[Plot]:  # noqa: A002
    """``POST /v1/plots/simulation?format=``: the scene drawn as position, force and energy."""
    return Call("POST", "/v1/plots/simulation", "plot", _image, json=_body(device=device, scene=scene),
                params={"format": format})


def plot_boundary(device: DeviceLike, controller: PartLike | None = None, *, damping_max: float | None = None,
                  points: int | None = None, format: ImageFormat = "png") -> Call[Plot]:  # noqa: A002
    """``POST /v1/plots/boundary?format=``: the stability boundary K_cr(B) with its optimum.

    ``controller`` is the rendered wall on the boundary, ``{"mass": M [kg], "velocity_filter": {...}}`` (as
    :func:`boundary`; default today's wall)."""
    return Call("POST", "/v1/plots/boundary", "plot", _image,
                json=_body(device=device, controller=controller, damping_max=damping_max, points=points),
                params={"format": format})


def plot_bode(device: DeviceLike, controller: PartLike | None = None, *, points: int | None = None,
              format: ImageFormat = "png") -> Call[Plot]:  # noqa: A002
    """``POST /v1/plots/bode?format=``: Bode diagram of the sampled loop with the crossovers of K_cr(B) marked."""
    return Call("POST", "/v1/plots/bode", "plot", _image,
                json=_body(device=device, controller=controller, points=points), params={"format": format})


def submit_study(request: PartLike) -> Call[StudyCreated]:
    """``POST /v1/studies``: queue a design-space study (problem, base device, sweep); answers its id."""
    return Call("POST", "/v1/studies", "submit", _model(StudyCreated), json=_part(request))


def study(study_id: str) -> Call[StudyStatus]:
    """``GET /v1/studies/{id}``: status, progress and rate of a study."""
    return Call("GET", f"/v1/studies/{_id(study_id)}", "read", _model(StudyStatus))


def studies(*, offset: int | None = None, limit: int | None = None, status: str | None = None) -> Call[StudyList]:
    """``GET /v1/studies``: the studies, newest first."""
    params = {k: v for k, v in (("offset", offset), ("limit", limit), ("status", status)) if v is not None}
    return Call("GET", "/v1/studies", "read", _model(StudyList), params=params)


def cancel_study(study_id: str, *, purge: bool = False) -> Call[StudyStatus | None]:
    """``DELETE /v1/studies/{id}``: cancel a queued or running study (stored rows stay); ``purge`` also deletes
    the study and its rows (the answer is then None: 204)."""
    def parse(response: httpx.Response) -> StudyStatus | None:
        return None if response.status_code == 204 else StudyStatus.model_validate_json(response.content)

    return Call("DELETE", f"/v1/studies/{_id(study_id)}", "read", parse, params={"purge": "true"} if purge else None)


@dataclasses.dataclass(frozen=True)
class Export(Plot):
    """Every stored row of a study as the service wrote it: CSV text or Parquet bytes (``.save(path)``)."""


def export_study(study_id: str, format: Literal["csv", "parquet"] = "csv") -> Call[Export]:  # noqa: A002
    """``GET /v1/studies/{id}/results?format=csv|parquet``: every stored row, streamed."""
    if format not in ("csv", "parquet"):
        raise ValueError("format: must be csv or parquet (the json pages come from study_results)")

    return Call("GET", f"/v1/studies/{_id(study_id)}/results", "results", _export, params={"format": format})


def study_results(study_id: str, *, offset: int | None = None, limit: int | None = None) -> Call[StudyResults]:
    """``GET /v1/studies/{id}/results``: one page of result rows (``next_offset`` gives the next)."""
    params = {k: v for k, v in (("offset", offset), ("limit", limit)) if v is not None}
    return Call("GET", f"/v1/studies/{_id(study_id)}/results", "results", _model(StudyResults), params=params)


def plot_study(study_id: str, y: str, x: str, *, x2: str | None = None,
               format: ImageFormat = "png") -> Call[Plot]:  # noqa: A002
    """``GET /v1/studies/{id}/plot``: result ``y`` against swept path ``x`` (line) or ``x`` and ``x2`` (map)."""
    params = {"y": y, "x": x, "format": format, **({"x2": x2} if x2 is not None else {})}
    return Call("GET", f"/v1/studies/{_id(study_id)}/plot", "plot", _image, params=params)


def _id(study_id: str) -> str:
    # An id is a path segment: refuse anything that would change the path.
    if not study_id or any(ch in study_id for ch in "/?#%") or study_id in (".", ".."):
        raise ValueError(f"study_id: {study_id!r} is not a study id")
    return study_id
