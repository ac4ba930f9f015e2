"""GET /v1/presets: the chapter's devices as full device objects."""

from typing import Any

from fastapi import APIRouter

from models.device import PRESETS, Device

router = APIRouter(prefix="/v1", tags=["presets"])


@router.get("/presets")
def presets() -> dict[str, Any]:
    return {name: Device(preset=name).model_dump(exclude={"preset"}) for name in sorted(PRESETS)}
