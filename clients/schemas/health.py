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
