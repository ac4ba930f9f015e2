"""POST /v1/design/hardware with free = encoder_resolution | coulomb_friction: the hook into the hardware route
(optim/hardware/quantisation.py does the work)."""

from __future__ import annotations

import dataclasses

from optim.hardware.quantisation import QUANTISATION_FREE, design_quantisation
from optim.nonlinear_verification import verify_nonlinear
from optim.stability.nonlinear import analyse_nonlinear
from service.executor import BoundedExecutor
from service.routes.analysis import nonlinear_verification_out
from service.schemas.design_hardware import HardwareDesignRequest, HardwareDesignResponse

__all__ = ["QUANTISATION_FREE", "quantisation_answer"]


def _verify(device, free: str, value: float, stiffness: float):
    """The simulation's check of the answer: optim.nonlinear_verification at the device with the answer."""
    dev = device.model_copy(update={free: value})
    nl = analyse_nonlinear(dev, stiffness, 0.0)
    return verify_nonlinear(dev, stiffness, 0.0, nl)


async def quantisation_answer(request: HardwareDesignRequest, compute: BoundedExecutor) -> HardwareDesignResponse:
    stiffness = request.target.stiffness
    assert stiffness is not None      # the request's validator refused it otherwise
    d = await compute.arun(design_quantisation, request.device, stiffness, request.free, cost_ms=None)
    block = dataclasses.asdict(d)
    for key in ("status", "free", "direction", "value", "elapsed_ms"):
        block.pop(key)
    if request.verify and d.value is not None:
        v = await compute.arun(_verify, request.device, request.free, d.value, stiffness, cost_ms=None)
        block["simulation"] = nonlinear_verification_out(v)
    controller = {"stiffness": stiffness, "damping": 0.0} if d.status == "optimal" else None
    return HardwareDesignResponse(status=d.status, free=d.free, direction=d.direction, value=d.value,
                                  controller=controller, reason=d.reason, quantisation=block,
                                  limiting_target="stiffness", elapsed_ms=d.elapsed_ms)
