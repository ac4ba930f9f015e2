"""Regenerate clients/schemas from the current app's /openapi.json (the step its __init__ describes).

    PYTHONPATH=. python scripts/client_schemas.py --codegen /path/to/datamodel-codegen --out /tmp/client_schemas

writes the pruned schema (the client's response models and the types nested in them, renamed
``<module>.<Name>``, without input bounds and property titles) and, with ``--codegen``, runs
datamodel-code-generator on it (it is not a dependency of zwidth: install it in a throw-away venv).
Compare the output with clients/schemas, carry over the hand edits listed there, and commit;
tests/clients/test_client_schemas.py says whether the result matches the server.
"""

from __future__ import annotations

import argparse
import json
import subprocess
from pathlib import Path
from typing import Any

#: The client module of each response model; a nested type used by several modules goes to ``common``,
#: the device's own blocks to ``device``.
GROUPS = {
    "analysis": ["StabilityResponse", "BoundaryResponse", "ForceFeedforwardResponse"],
    "design": ["StiffnessDesignResponse", "InertiaResponse", "HardwareDesignResponse"],
    "simulate": ["SimulateResponse"],
    "identify": ["IdentifyResponse"],
    "studies": ["StudyCreated", "StudyList", "StudyResults", "StudyStatus"],
    "health": ["Health", "Readiness"],
    "device": ["Device"],
}
# Input rules the server applies to requests; an answer it sends has passed them already.
DROP = {"minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum", "minLength", "maxLength", "pattern",
        "minItems", "maxItems"}
CODEGEN_OPTIONS = ["--input-file-type", "openapi", "--output-model-type", "pydantic_v2.BaseModel",
                   "--target-python-version", "3.11", "--use-annotated", "--use-double-quotes",
                   "--enum-field-as-literal", "all", "--base-class", "clients.schemas.answer.Answer", "--treat-dot-as-module",
                   "--disable-timestamp", "--use-schema-description", "--strict-nullable"]


def _refs(node: Any, out: set[str]) -> set[str]:
    if isinstance(node, dict):
        for key, value in node.items():
            if key == "$ref":
                out.add(value.rsplit("/", 1)[-1])
            else:
                _refs(value, out)
    elif isinstance(node, list):
        for value in node:
            _refs(value, out)
    return out


def _closure(components: dict[str, Any], name: str) -> set[str]:
    seen, todo = set(), [name]
    while todo:
        n = todo.pop()
        if n not in seen:
            seen.add(n)
            todo.extend(_refs(components[n], set()))
    return seen


def prune(openapi: dict[str, Any]) -> dict[str, Any]:
    """The client's part of ``openapi``: response components only, each named ``<module>.<Name>``."""
    components = openapi["components"]["schemas"]
    users: dict[str, set[str]] = {}
    for group, roots in GROUPS.items():
        for root in roots:
            for n in _closure(components, root):
                users.setdefault(n, set()).add(group)
    device = _closure(components, "Device")
    module = {n: "device" if n in device else next(iter(g)) if len(g) == 1 else "common" for n, g in users.items()}

    def clean(node: Any, in_properties: bool = False) -> Any:
        if isinstance(node, list):
            return [clean(v, in_properties) for v in node]
        if not isinstance(node, dict):
            return node
        out: dict[str, Any] = {}
        for key, value in node.items():
            if key == "$ref":
                name = value.rsplit("/", 1)[-1]
                out[key] = f"#/components/schemas/{module[name]}.{name}"
            elif key in DROP or (key == "title" and in_properties) or (key == "additionalProperties"
                                                                          and value is False):
                continue
            elif key == "properties":
                out[key] = {p: clean(v, True) for p, v in value.items()}
            else:
                out[key] = clean(value, in_properties and key in ("anyOf", "oneOf", "allOf", "items"))
        return out

    return {"openapi": openapi["openapi"], "info": openapi["info"], "paths": {},
            "components": {"schemas": {f"{module[n]}.{n}": clean(components[n]) for n in sorted(module)}}}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="directory for pruned.json and the models")
    parser.add_argument("--codegen", help="path of datamodel-codegen (else only pruned.json is written)")
    args = parser.parse_args(argv)
    from service.app import create_app

    args.out.mkdir(parents=True, exist_ok=True)
    pruned = args.out / "pruned.json"
    pruned.write_text(json.dumps(prune(create_app().openapi()), indent=1), encoding="utf-8")
    print(f"wrote {pruned}")
    if args.codegen:
        subprocess.run([args.codegen, "--input", str(pruned), *CODEGEN_OPTIONS, "--output", str(args.out / "schemas")],
                       check=True)
        print(f"wrote {args.out / 'schemas'}: black -l 120, then the hand edits of clients/schemas/__init__.py")


if __name__ == "__main__":
    main()
