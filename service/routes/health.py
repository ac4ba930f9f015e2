"""GET /healthz: liveness, open even when the /v1 routes need a token."""

from fastapi import APIRouter
from pydantic import BaseModel, Field

router = APIRouter(tags=["health"])


class Health(BaseModel):
    model_config = {"json_schema_extra": {"examples": [{"status": "ok", "version": "0.1.0"}]}}
    status: str = Field(description="'ok' when the service answers")
    version: str = Field(description="zwidth version")


@router.get("/healthz", response_model=Health, operation_id="healthz", summary="Liveness probe")
def healthz() -> Health:
    from ..app import VERSION

    return Health(status="ok", version=VERSION)
