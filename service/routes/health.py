"""GET /healthz."""

from fastapi import APIRouter

router = APIRouter(tags=["health"])


@router.get("/healthz")
def healthz() -> dict[str, str]:
    from ..app import VERSION

    return {"status": "ok", "version": VERSION}
