"""/v1/studies: submit, follow, export, plot and cancel batch design-space studies (issue 8)."""

from __future__ import annotations

import asyncio
import random
import time
import uuid
from typing import Annotated, Literal

from fastapi import APIRouter, HTTPException, Query, Request, Response
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse, StreamingResponse
from starlette.concurrency import run_in_threadpool

from optim.errors import InputError
from optim.studies.problems import StudyInputError

from ..errors import StoreUnavailable
from ..executor import Compute
from ..plot_labels import base_device_title, problem_label, result_label
from ..schemas.plots import FormatQuery, image_format
from ..schemas.studies import StudyCreated, StudyList, StudyRequest, StudyResults, StudyStatus
from ..studies.blocks import read_schema
from ..studies.export import (
    block_columns,
    columns,
    csv_block_chunks,
    csv_chunks,
    flat_row,
    parquet_block_chunks,
    parquet_chunks,
    scan_columns,
)
from ..studies.lifespan import study_lifespan
from ..studies.plot import plot_study
from ..studies.runner import StudyRunner, plan_from_request

router = APIRouter(prefix="/v1/studies", tags=["studies"], lifespan=study_lifespan)

MAX_PAGE = 10_000
#: Largest paging offset: 2^53 − 1, the largest integer every JSON client holds exactly (and far inside the
#: 64-bit integers of SQLite and PostgreSQL, which answered a larger one with OverflowError: a 500).
MAX_OFFSET = 2**53 - 1
MAX_PLOT_POINTS = 200_000
#: Retry-After [s] of the 429 past ZWIDTH_STUDY_MAX_ACTIVE active studies.
STUDY_RETRY_AFTER_S = 30


def _runner(request: Request) -> StudyRunner:
    runner = getattr(request.app.state, "study_runner", None)
    if runner is None:
        raise StoreUnavailable()
    return runner


def _study(runner: StudyRunner, study_id: str) -> dict:
    row = runner.store.get(study_id)
    if row is None:
        raise HTTPException(status_code=404, detail=f"no study {study_id!r}")
    return row


def _invalid(loc: list, msg: str) -> RequestValidationError:
    return RequestValidationError([{"type": "value_error", "loc": tuple(loc), "msg": msg}])


def _body_loc(field: str, sweep_paths) -> list:
    """'sweep.device.cable.stiffness.num' -> ['body', 'sweep', 'device.cable.stiffness', 'num'] (pydantic's shape)."""
    if field.startswith("sweep."):
        rest = field.removeprefix("sweep.")
        for path in sorted(sweep_paths, key=len, reverse=True):
            if rest == path or rest.startswith(path + "."):
                tail = rest.removeprefix(path).lstrip(".")
                return ["body", "sweep", path, *([tail] if tail else [])]
    return ["body", *field.split(".")]


def _status(row: dict) -> StudyStatus:
    done, total = row["done"], row["total"]
    rate = eta = None
    if row["run_started_at"] is not None:
        end = row["finished_at"] if row["status"] != "running" and row["finished_at"] else time.time()
        elapsed = end - row["run_started_at"]
        progressed = done - row["run_start_done"]
        if elapsed > 0 and progressed > 0:
            rate = progressed / elapsed
    if row["status"] == "done":
        eta = 0.0
    elif row["status"] == "running" and rate:
        eta = (total - done) / rate
    req = row["request"]
    return StudyStatus(id=row["id"], name=req.get("name"), problem=row["problem"], status=row["status"],
                       total=total, done=done, failed=row["failed"], progress=done / total if total else 1.0,
                       rate=rate, eta_s=eta, created_at=row["created_at"], started_at=row["run_started_at"],
                       resumed_from=row["run_start_done"],
                       finished_at=row["finished_at"], error=row["error"], sweep=list(req.get("sweep", {})))


@router.post("", status_code=202, response_model=StudyCreated,
             responses={429: {"description": "too many studies queued or running (ZWIDTH_STUDY_MAX_ACTIVE); "
                                             "the Retry-After header says when to try again",
                              "content": {"application/json": {"schema": {
                                  "type": "object", "properties": {"detail": {"type": "string"}},
                                  "required": ["detail"]}}}}})
def submit_study(req: StudyRequest, request: Request) -> StudyCreated:
    """Plan the study, store the request (on disk before answering), queue it: 202 with its id."""
    runner = _runner(request)
    body = req.model_dump(mode="json")
    if req.sampling.design == "latin_hypercube" and req.sampling.seed is None:
        body["sampling"]["seed"] = random.SystemRandom().randrange(2**63)  # stored: a resume redraws the same
    try:
        plan = plan_from_request(body)
    except StudyInputError as exc:
        raise _invalid(_body_loc(exc.field, body["sweep"]), exc.msg) from exc
    cap = getattr(request.app.state, "study_max_active", None)
    if cap is not None and runner.store.count_active() >= cap:
        raise HTTPException(status_code=429, headers={"Retry-After": str(STUDY_RETRY_AFTER_S)},
                            detail=f"{cap} studies are already queued or running (ZWIDTH_STUDY_MAX_ACTIVE); "
                                   "retry when one has finished, or cancel one")
    study_id = str(uuid.uuid4())
    runner.store.create(study_id, req.problem, body, plan.total)
    runner.notify()
    return StudyCreated(id=study_id, status="queued", points=plan.total, problem=req.problem)


@router.get("", response_model=StudyList)
def list_studies(request: Request, offset: Annotated[int, Query(ge=0, le=MAX_OFFSET)] = 0,
                 limit: Annotated[int, Query(ge=1, le=1000)] = 100,
                 status: Literal["queued", "running", "cancelling", "done", "cancelled", "failed"] | None = None
                 ) -> StudyList:
    rows = _runner(request).store.list(limit, offset, status)
    return StudyList(studies=[_status(r) for r in rows], offset=offset, limit=limit)


@router.get("/{study_id}", response_model=StudyStatus)
def get_study(study_id: str, request: Request) -> StudyStatus:
    return _status(_study(_runner(request), study_id))


#: How long a cancel waits for the study's owner to stop before answering 202 "cancelling" [s].
CANCEL_WAIT_S = 2.0


@router.delete("/{study_id}", response_model=StudyStatus, responses={
    202: {"model": StudyStatus, "description": "cancelling: the study's coordinator (maybe in another service "
                                               "process) stops at its next chunk; no row is written from now on"},
    204: {"description": "purged"},
    409: {"description": "purge refused: the study is still active or stopping; retry once it is cancelled"}})
async def cancel_study(study_id: str, request: Request, purge: bool = False) -> StudyStatus | Response:
    """Cancel a queued or running study (stored results stay); ``purge=true`` also deletes it and its results.

    200 with ``cancelled`` (or the study's final state) once it has stopped; 202 with ``cancelling`` when
    its coordinator has not stopped within a moment.  Either way no result row is written after the answer.
    A purge cancels too, and answers 409 at once while the study is still running or stopping (retry)."""
    runner = _runner(request)
    store = runner.store
    row = await run_in_threadpool(_study, runner, study_id)
    outcome = await run_in_threadpool(store.cancel, study_id)
    if outcome:
        runner.cancel(study_id)   # this process's coordinator, if it runs the study, stops without waiting
    if purge:   # at once: a study still running or stopping is never purged under its writer
        gone = await run_in_threadpool(store.delete, study_id)
        if gone == "active":
            raise HTTPException(status_code=409, detail="the study is still stopping; purge it again in a moment")
        return Response(status_code=204)
    deadline = time.monotonic() + CANCEL_WAIT_S
    while outcome == "cancelling" and time.monotonic() < deadline:
        await asyncio.sleep(0.05)
        outcome = await run_in_threadpool(store.status, study_id)
    st = _status(await run_in_threadpool(store.get, study_id) or row)
    if st.status == "cancelling":
        return JSONResponse(st.model_dump(mode="json"), status_code=202)
    return st


@router.get("/{study_id}/results", response_model=StudyResults,
            responses={200: {"content": {"text/csv": {}, "application/vnd.apache.parquet": {}}}})
def study_results(study_id: str, request: Request, format: Literal["json", "csv", "parquet"] = "json",
                  offset: Annotated[int, Query(ge=0, le=MAX_OFFSET)] = 0,
                  limit: Annotated[int, Query(ge=1, le=MAX_PAGE)] = 1000) -> StudyResults | Response:
    """Stored results in point order: JSON paged by offset/limit; CSV and Parquet whole."""
    runner = _runner(request)
    row = _study(runner, study_id)
    paths = list(row["request"].get("sweep", {}))
    if format == "json":
        recs = runner.store.results(study_id, offset, limit)
        rows = [flat_row(paths, r) for r in recs]
        return StudyResults(id=study_id, status=row["status"], total=row["total"], offset=offset, limit=limit,
                            next_offset=offset + len(rows) if len(rows) == limit else None,
                            columns=columns(paths, rows), rows=rows)
    def rows():  # a fresh pass over the store each time: exports stream, they are not held in memory
        return (flat_row(paths, r) for r in runner.store.iter_results(study_id))
    # the columns from the blocks' schemas (issue 20: no pass over every row), else from the rows
    scanned = block_columns(paths, (read_schema(d) for _, d in runner.store.iter_blocks(study_id)))
    cols, kinds = scanned or scan_columns(paths, rows())
    headers = {"Content-Disposition": f'attachment; filename="study-{study_id}.{format}"'}
    if format == "csv":
        body = csv_block_chunks(cols, paths, runner.store.iter_blocks(study_id)) if scanned else csv_chunks(cols, rows())
        return StreamingResponse(body, media_type="text/csv", headers=headers)
    body = (parquet_block_chunks(cols, kinds, paths, runner.store.iter_blocks(study_id)) if scanned
            else parquet_chunks(cols, kinds, rows()))
    return StreamingResponse(body, media_type="application/vnd.apache.parquet", headers=headers)


@router.get("/{study_id}/plot", response_class=Response, responses={200: {"description": "the figure", "content": {
    "image/png": {"schema": {"type": "string", "format": "binary"}},
    "image/svg+xml": {"schema": {"type": "string", "format": "binary"}}}}})
async def study_plot(study_id: str, request: Request, compute: Compute, y: str, x: str, x2: str | None = None,
                     format: FormatQuery = None) -> Response:  # noqa: A002
    """Result ``y`` against swept ``x`` (line) or against ``x`` and ``x2`` (heatmap)."""
    format = image_format(format)  # noqa: A001
    runner = _runner(request)
    row = await run_in_threadpool(_study, runner, study_id)
    paths = list(row["request"].get("sweep", {}))
    for name, value in (("x", x), ("x2", x2)):
        if value is not None and value not in paths:
            raise _invalid(["query", name], f"{value!r} is not swept in this study; swept: {', '.join(paths)}")
    if x2 == x:
        raise _invalid(["query", "x2"], "must differ from x")
    if row["done"] > MAX_PLOT_POINTS:
        raise _invalid(["query", "x"], f"the study has more than {MAX_PLOT_POINTS} points to draw; export it instead")
    sweep = row["request"].get("sweep", {})
    log_paths = {p: spec.get("scale") == "log" for p, spec in sweep.items() if isinstance(spec, dict)}
    try:  # read and drawn in a compute worker, under the request time budget
        device = row["request"].get("base", {}).get("device") or {}
        title = (f"{result_label(y, device)}: {problem_label(row['problem'])} study {study_id[:8]}\n"
                 f"{base_device_title(device, paths)}")
        image = await compute.arun(plot_study, runner.store.url, study_id, paths, y, x, x2, format, title,
                                   log_paths, device, cost_ms=None)
    except InputError as exc:
        raise _invalid(["query", exc.field], exc.rule) from None
    return Response(image, media_type="image/png" if format == "png" else "image/svg+xml")
