"""The client's own response models (clients/schemas) held against /openapi.json of the current app.

For every model the client parses, and recursively for the models nested in it: the same field names,
the same required fields, the same nullable fields and the same allowed values of a ``Literal``.  A field
the server adds without the client fails here by name, and so does a renamed or newly nullable one.
"""

from __future__ import annotations

import copy
import types
import typing
from typing import Any, Literal, Union

import pytest
from pydantic import BaseModel

from clients import calls, schemas

from .conftest import openapi_document

REGENERATE = "update clients/schemas (regenerate as its __init__ says)"


@pytest.fixture(scope="module")
def openapi() -> dict[str, Any]:
    return openapi_document()


# ------------------------------------------------------------------------------------------------ the client side
def _flatten(annotation: Any) -> list[Any]:
    """The leaves of a type: the members of unions, lists and dicts (values)."""
    origin = typing.get_origin(annotation)
    if origin in (Union, types.UnionType):
        return [leaf for arg in typing.get_args(annotation) for leaf in _flatten(arg)]
    if origin in (list, tuple, set, frozenset):
        return [leaf for arg in typing.get_args(annotation) if arg is not Ellipsis for leaf in _flatten(arg)]
    if origin is dict:
        return _flatten(typing.get_args(annotation)[1])
    return [annotation]


def _client_field(annotation: Any) -> tuple[bool, set[type[BaseModel]], set[Any] | None]:
    leaves = _flatten(annotation)
    nullable = type(None) in leaves
    nested = {leaf for leaf in leaves if isinstance(leaf, type) and issubclass(leaf, BaseModel)}
    literals = [leaf for leaf in leaves if typing.get_origin(leaf) is Literal]
    values = {v for leaf in literals for v in typing.get_args(leaf)} if literals else None
    return nullable, nested, values


# ------------------------------------------------------------------------------------------------ the server side
def _variants(prop: dict[str, Any]) -> list[dict[str, Any]]:
    """The alternatives of a property schema, with arrays and maps opened to their items."""
    out: list[dict[str, Any]] = []
    for alt in prop.get("anyOf", prop.get("oneOf", [prop])):
        if alt.get("type") == "array" and isinstance(alt.get("items"), dict):
            out.extend(_variants(alt["items"]))
        elif alt.get("type") == "object" and isinstance(alt.get("additionalProperties"), dict):
            out.extend(_variants(alt["additionalProperties"]))
        elif "allOf" in alt and len(alt["allOf"]) == 1:
            out.extend(_variants(alt["allOf"][0]))
        else:
            out.append(alt)
    return out


def _server_field(prop: dict[str, Any]) -> tuple[bool, set[str], set[Any] | None]:
    alts = _variants(prop)
    nullable = any(a.get("type") == "null" for a in alts) or any(
        a.get("type") == "null" for a in prop.get("anyOf", [])) or "null" in (prop.get("type") or [])
    refs = {a["$ref"].rsplit("/", 1)[-1] for a in alts if "$ref" in a}
    enums = [a for a in alts if "enum" in a or "const" in a]
    values = {v for a in enums for v in a.get("enum", [a.get("const")])} if enums else None
    return nullable, refs, values


# ------------------------------------------------------------------------------------------------ the comparison
def differences(model: type[BaseModel], name: str, components: dict[str, Any],
                seen: set[str] | None = None) -> list[str]:
    """Every way the client's ``model`` differs from the server's component ``name`` (recursively)."""
    seen = set() if seen is None else seen
    if name in seen:
        return []
    seen.add(name)
    if name not in components:
        return [f"{name}: no such component in /openapi.json (the client's {model.__name__} names a schema the "
                f"server no longer has)"]
    server = components[name]
    props, required = server.get("properties", {}), set(server.get("required", []))
    fields = model.model_fields
    out = [f"{name}.{f}: the server sends it, the client's {model.__name__} has no such field ({REGENERATE})"
           for f in sorted(set(props) - set(fields))]
    out += [f"{name}.{f}: the client's {model.__name__} has it, the server's schema does not ({REGENERATE})"
            for f in sorted(set(fields) - set(props))]
    for f in sorted(set(props) & set(fields)):
        where = f"{name}.{f}"
        field = fields[f]
        if field.is_required() != (f in required):
            out.append(f"{where}: required on the {'client' if field.is_required() else 'server'} only")
        c_null, c_nested, c_values = _client_field(field.annotation)
        s_null, s_refs, s_values = _server_field(props[f])
        if c_null != s_null:
            out.append(f"{where}: nullable on the {'client' if c_null else 'server'} only")
        if c_values is not None and s_values is not None and c_values != s_values:
            out.append(f"{where}: allowed values differ: client {sorted(map(str, c_values))}, "
                       f"server {sorted(map(str, s_values))}")
        if {m.__name__ for m in c_nested} != s_refs:
            out.append(f"{where}: nested models differ: client {sorted(m.__name__ for m in c_nested)}, "
                       f"server {sorted(s_refs)}")
            continue
        for nested in c_nested:
            out += differences(nested, nested.__name__, components, seen)
    return out


@pytest.mark.parametrize("name", sorted(schemas.RESPONSES))
def test_client_model_matches_the_servers_schema(openapi, name):
    problems = differences(schemas.RESPONSES[name], name, openapi["components"]["schemas"])
    assert not problems, "the client's models drifted from /openapi.json:\n  " + "\n  ".join(problems)


def _calls() -> list[calls.Call]:
    dev = {"preset": "lhifam"}
    return [calls.health(), calls.stability(dev), calls.boundary(dev), calls.force_feedforward(dev),
            calls.design_stiffness(dev), calls.design_inertia(dev), calls.design_hardware(dev, "delay"),
            calls.identify({}), calls.simulate(dev, {}), calls.submit_study({}), calls.study("s"),
            calls.studies(), calls.study_results("s"),
            calls.workspace({"kinematics": {"preset": "planar-2link"}}, {"explicit": [[0.3, 1.0]]})]


def test_each_call_parses_the_model_its_route_answers(openapi):
    """The client reads each endpoint's answer with the model that /openapi.json names for it."""
    for call in _calls():
        path = call.path.replace("/s/", "/{study_id}/") if call.path.count("/") > 3 else call.path
        path = "/v1/studies/{study_id}" if path == "/v1/studies/s" else path
        op = openapi["paths"][path][call.method.lower()]
        ok = next(r for code, r in op["responses"].items() if code.startswith("2"))
        ref = ok["content"]["application/json"]["schema"]["$ref"].rsplit("/", 1)[-1]
        assert call.parse.__qualname__ == f"parse {ref}", (call.method, path)
        assert ref in schemas.RESPONSES


def test_every_response_component_of_a_parsed_route_has_a_client_model(openapi):
    """No JSON answer of the API that the client reads is left without a model (presets are Device objects)."""
    parsed = {c.parse.__qualname__.removeprefix("parse ") for c in _calls()}
    assert parsed <= set(schemas.RESPONSES)
    assert set(schemas.RESPONSES) - parsed == {"Device", "Readiness"}


def test_a_field_added_on_the_server_fails_by_name(openapi):
    """The comparison can fail: a new field, a field made nullable, a new status value, a changed nested model."""
    components = copy.deepcopy(openapi["components"]["schemas"])
    components["StabilityResponse"]["properties"]["new_field"] = {"type": "number"}
    components["StabilityResponse"]["required"].append("new_field")
    components["CrossoverOut"]["properties"]["frequency"] = {"anyOf": [{"type": "number"}, {"type": "null"}]}
    status = components["StiffnessDesignResponse"]["properties"]["status"]
    status.setdefault("enum", []).append("maybe")
    problems = differences(schemas.StabilityResponse, "StabilityResponse", components)
    assert any(p.startswith("StabilityResponse.new_field: the server sends it") for p in problems), problems
    assert "CrossoverOut.frequency: nullable on the server only" in problems, problems
    design = differences(schemas.StiffnessDesignResponse, "StiffnessDesignResponse", components)
    assert any(p.startswith("StiffnessDesignResponse.status: allowed values differ") for p in design), design
    assert differences(schemas.StabilityResponse, "StabilityResponse", openapi["components"]["schemas"]) == []


def test_an_older_client_reads_a_newer_servers_answer():
    """extra='allow' everywhere: a field the server adds later is kept, not refused."""
    health = schemas.Health.model_validate({"status": "ok", "version": "9", "uptime_s": 3.0})
    assert health.model_dump()["uptime_s"] == 3.0
    for model in _all_models():
        assert model.model_config.get("extra") == "allow", model.__name__


def _all_models() -> set[type[BaseModel]]:
    todo, seen = list(schemas.RESPONSES.values()), set()
    while todo:
        m = todo.pop()
        if m in seen:
            continue
        seen.add(m)
        for f in m.model_fields.values():
            todo.extend(_client_field(f.annotation)[1])
    return seen


def test_the_client_cable_has_the_servers_natural_frequency():
    """The one derived quantity the client computes itself (the presets table's ω_n, eq. 24) is the model's."""
    from models.device import PRESETS, Device

    cables = [Device(preset=name).cable for name in PRESETS]
    assert any(cables)
    for cable in filter(None, cables):
        mine = schemas.Cable.model_validate(cable.model_dump(mode="json"))
        assert mine.natural_frequency == cable.natural_frequency
