"""GET /healthz (liveness) and GET /readyz (readiness with the compute queue), open even when the /v1 routes
need a token.

Both are ``async def`` and touch nothing but memory: they answer on the event loop, never wait for a thread
of the pool nor for a compute worker, so they stay fast however loaded the service is.
"""

from fastapi import APIRouter, Request
from fastapi.responses import JSONResponse
from pydantic import BaseModel, Field

router = APIRouter(tags=["health"])


class Health(BaseModel):
    model_config = {"json_schema_extra": {"examples": [{"status": "ok", "version": "0.1.0"}]}}
    status: str = Field(description="'ok' when the service answers")
    version: str = Field(description="zwidth version")


class ComputeQueue(BaseModel):
    depth: int = Field(description="expensive calls waiting for a compute worker")
    max_depth: int = Field(description="waiting calls beyond which a new one is refused with 503 "
                                       "(ZWIDTH_COMPUTE_QUEUE)")
    workers: int = Field(description="compute worker processes (ZWIDTH_COMPUTE_WORKERS)")
    busy: int = Field(description="workers computing now")
    replaced: int = Field(description="workers killed and replaced since the start (budget overruns, crashes)")


class Degraded(BaseModel):
    family: str = Field(description="the route family that answers 503 now, e.g. 'studies' (/v1/studies)")
    reason: str = Field(description="why, in general terms (the cause is in the server's log)")


class Readiness(BaseModel):
    model_config = {"json_schema_extra": {"examples": [
        {"ready": True, "warm": True, "version": "0.1.0", "degraded": [],
         "queue": {"depth": 0, "max_depth": 32, "workers": 2, "busy": 1, "replaced": 0}}]}}
    ready: bool = Field(description="the service takes requests at full speed: the warm-up is done (or disabled)")
    warm: bool = Field(description="every compute worker is started and warm (numerics imported, CasADi design "
                                   "solvers built): the first design does not pay for either")
    version: str = Field(description="zwidth version")
    queue: ComputeQueue
    degraded: list[Degraded] = Field(default_factory=list, description=(
        "route families that answer 503 whatever the request (e.g. the study store could not be opened: a "
        "read-only or missing HOME); the rest of the service serves. Empty when every family serves"))


@router.get("/healthz", response_model=Health, operation_id="healthz", summary="Liveness probe")
async def healthz() -> Health:
    from ..app import VERSION

    return Health(status="ok", version=VERSION)


@router.get("/readyz", response_model=Readiness, operation_id="readyz",
            summary="Readiness probe: 200 once the compute workers are warm, else 503; the compute queue and "
                    "the route families that answer 503 (degraded)",
            responses={503: {"model": Readiness, "description": "still warming up"}})
async def readyz(request: Request) -> JSONResponse:
    from ..app import VERSION

    state = request.app.state.executor.state()
    settings = getattr(request.app.state, "settings", None)
    ready = state.warm or not getattr(settings, "prestart_workers", True)
    degraded = []
    if getattr(request.app.state, "study_error", None):
        degraded.append(Degraded(family="studies", reason=request.app.state.study_error))
    body = Readiness(ready=ready, warm=state.warm, version=VERSION, degraded=degraded,
                     queue=ComputeQueue(depth=state.depth, max_depth=state.max_depth, workers=state.workers,
                                        busy=state.busy, replaced=state.replaced))
    return JSONResponse(body.model_dump(), status_code=200 if ready else 503)
