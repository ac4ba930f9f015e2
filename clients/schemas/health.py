"""The service's health answers as this client reads them (generated: see clients/schemas/__init__.py)."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field

from clients.schemas.answer import Answer


class ComputeQueue(Answer):
    depth: Annotated[int, Field(description="expensive calls waiting for a compute worker")]
    max_depth: Annotated[
        int, Field(description="waiting calls beyond which a new one is refused with 503 (ZWIDTH_COMPUTE_QUEUE)")
    ]
    workers: Annotated[int, Field(description="compute worker processes (ZWIDTH_COMPUTE_WORKERS)")]
    busy: Annotated[int, Field(description="workers computing now")]
    replaced: Annotated[
        int, Field(description="workers killed and replaced since the start (budget overruns, crashes)")
    ]


class Degraded(Answer):
    family: Annotated[str, Field(description="the route family that answers 503 now, e.g. 'studies' (/v1/studies)")]
    reason: Annotated[str, Field(description="why, in general terms (the cause is in the server's log)")]


class Health(Answer):
    status: Annotated[str, Field(description="'ok' when the service answers")]
    version: Annotated[str, Field(description="zwidth version")]


class Readiness(Answer):
    ready: Annotated[
        bool, Field(description="the service takes requests at full speed: the warm-up is done (or disabled)")
    ]
    warm: Annotated[
        bool,
        Field(
            description=(
                "every compute worker is started and warm (numerics imported, CasADi design solvers built): the first"
                " design does not pay for either"
            )
        ),
    ]
    version: Annotated[str, Field(description="zwidth version")]
    queue: ComputeQueue
    degraded: Annotated[
        list[Degraded],
        Field(
            default_factory=list,
            description=(
                "route families that answer 503 whatever the request (e.g. the study store could not be opened: a"
                " read-only or missing HOME); the rest of the service serves. Empty when every family serves"
            ),
        ),
    ]
