"""One name per operation in /docs, /redoc and /openapi.json: a sentence summary and a snake_case operation id.

FastAPI's defaults are the route function's name, title-cased ("Design Stiffness Route", "Inertia") and
``design_stiffness_route_v1_design_stiffness_post``: uneven, and they change when a function is renamed.  A route
that names itself in its decorator keeps that name; every other route takes its name from ``NAMES`` (applied to the
OpenAPI document, the one place FastAPI reads them from).  The OpenAPI
descriptions are read from docstrings written for Sphinx; ``plain_descriptions`` shows their roles
(``:data:`PRESETS```) as code (``PRESETS``) for ReDoc and Swagger UI.
"""

from __future__ import annotations

import re
from typing import Any

__all__ = ["NAMES", "name_routes", "plain_descriptions"]

#: (method, path) → (operation id, summary)
NAMES: dict[tuple[str, str], tuple[str, str]] = {
    ("POST", "/v1/design/stiffness"): (
        "design_stiffness", "The stiffest safe wall (K, B) under margin, passivity, actuator and noise limits"),
    ("POST", "/v1/design/inertia"): (
        "design_inertia", "The lightest feel: force-feedforward gain K_f and filter cutoff, Pareto curve, grasps"),
    ("POST", "/v1/design/hardware"): (
        "design_hardware", "The hardware a target needs: sample time, delay, damping, mass or cable stiffness"),
    ("POST", "/v1/analysis/force-feedforward"): (
        "analyse_force_feedforward", "Critical force-feedforward gain K_f,cr with grasp, sensor filter and cable"),
    ("POST", "/v1/identify"): (
        "identify_device", "The device from a lab's measurements: parameters with intervals, fit, rigid or cable"),
    ("POST", "/v1/simulate"): (
        "simulate_scene", "A scene with only the effects it names, its verdict from the closed-loop poles"),
    ("POST", "/v1/plots/identify"): ("plot_identification", "Figure of an identification's fit (PNG or SVG)"),
    ("POST", "/v1/plots/robust"): ("plot_robust", "Figure of a robust design's margin over its box (PNG or SVG)"),
    ("POST", "/v1/plots/hardware"): ("plot_hardware", "Figure of the hardware trade-off curve (PNG or SVG)"),
    ("POST", "/v1/plots/simulation"): ("plot_simulation", "Figure of a simulated trajectory (PNG or SVG)"),
    ("POST", "/v1/studies"): ("submit_study", "Submit a design-space study (stored before the answer)"),
    ("GET", "/v1/studies"): ("list_studies", "The stored studies and their status"),
    ("GET", "/v1/studies/{study_id}"): ("get_study", "A study's status and progress"),
    ("DELETE", "/v1/studies/{study_id}"): ("cancel_study", "Cancel a queued or running study (its results stay)"),
    ("GET", "/v1/studies/{study_id}/results"): ("study_results", "A study's stored results (JSON pages or CSV)"),
    ("GET", "/v1/studies/{study_id}/plot"): ("plot_study", "Figure of a study's results (PNG or SVG)"),
}


def _generated(operation_id: str, method: str, path: str) -> bool:
    """Whether FastAPI made ``operation_id`` up (its unique id: the function's name, the path, the method)."""
    return operation_id.endswith(re.sub(r"\W", "_", path) + "_" + method.lower())


def name_routes(openapi: dict[str, Any]) -> dict[str, Any]:
    """``openapi`` with every operation that names itself nothing named from ``NAMES`` (a route whose decorator
    gives ``operation_id`` and ``summary`` keeps them)."""
    for path, item in openapi.get("paths", {}).items():
        for method, op in item.items():
            named = NAMES.get((method.upper(), path))
            if named is not None and _generated(op.get("operationId", ""), method, path):
                op["operationId"], op["summary"] = named
    return openapi


_ROLE = re.compile(r":(?:[a-z]+:)?[a-z]+:`~?([^`]+)`")


def plain_descriptions(node: Any) -> Any:
    """``node`` (an OpenAPI document or part of it) with Sphinx roles in its descriptions written as code."""
    if isinstance(node, dict):
        return {k: (_ROLE.sub(r"`\1`", v).replace("``", "`") if k == "description" and isinstance(v, str)
                    else plain_descriptions(v)) for k, v in node.items()}
    if isinstance(node, list):
        return [plain_descriptions(v) for v in node]
    return node
