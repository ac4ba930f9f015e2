"""Requirements are defined once (issue 19): the HTTP requests use optim's requirement models, so a bound, a
cross-field rule and its message exist in one place, and the 422 says what the numerics would say."""

from __future__ import annotations

import pytest
from pydantic import ValidationError

from optim.errors import InputError, from_validation
from optim.hardware.hardware_targets import HardwareTarget
from optim.stability.analysis import check_rung
from optim.stiffness import requirements as stiffness_requirements
from optim.stiffness.requirements import StiffnessRequirements
from optim.transparency.inertia_requirements import InertiaRequirements
from service.schemas.design_hardware import HardwareTargetIn
from service.schemas.design_stiffness import StiffnessRequirementsIn
from service.schemas.feedforward import InertiaRequirementsIn
from tests.service.conftest import LHIFAM_RIGID, make_client

HUMAN = {"mass": 2.0, "damping": 2.0, "stiffness": 10.0}

PAIRS = [(StiffnessRequirements, StiffnessRequirementsIn, {"uncertainty", "workspace"}),
         (InertiaRequirements, InertiaRequirementsIn, {"uncertainty"}), (HardwareTarget, HardwareTargetIn, set())]


@pytest.fixture(scope="module")
def client():
    with make_client() as c:
        yield c


@pytest.mark.parametrize("core, schema, added", PAIRS, ids=["stiffness", "inertia", "hardware"])
def test_the_request_model_is_optims_plus_the_box(core, schema, added):
    """The service's requirements are optim's model: the same fields with the same bounds, defaults and docs,
    the same validators, and nothing of their own but the robust design's box (and the stiffness design's
    workspace: the pose set of a multi-DOF design, optim.workspace.design, issue 33)."""
    assert issubclass(schema, core)
    assert set(schema.model_fields) - set(core.model_fields) == added
    for name, info in core.model_fields.items():
        mine = schema.model_fields[name]
        assert (mine.annotation, mine.default, mine.metadata, mine.description) == \
            (info.annotation, info.default, info.metadata, info.description), name
    assert schema.__pydantic_decorators__.model_validators.keys() == core.__pydantic_decorators__.model_validators.keys()
    assert not schema.__pydantic_decorators__.field_validators
    # the service adds JSON-number strictness only
    assert schema.model_config["strict"] is True and schema.model_config["extra"] == "forbid"


STIFFNESS_BAD = [{"min_gain_margin_db": -1}, {"min_gain_margin_db": 500}, {"max_damping": 0}, {"max_stiffness": 2e12},
                 {"max_force": 3}, {"max_penetration": 0.001}, {"quantization": 1e-5}, {"max_force_noise": 0.1},
                 {"bogus": 1}]
INERTIA_BAD = [{"cutoff_min_hz": 0}, {"cutoff_max_hz": 2e9}, {"filter_order": 5}, {"pareto_points": 1},
               {"target_apparent_mass": 0}, {"humans": []}, {"humans": [HUMAN] * 17},
               {"human_mass_range": {"min": 2, "max": 1}}, {"human_mass_range": {"min": 0, "max": 1}},
               {"humans": [HUMAN], "human_mass_range": {"min": 1, "max": 2}},
               {"objective": "target_apparent_mass"}, {"objective": "min_apparent_mass", "target_apparent_mass": 1.0},
               {"objective": "lightest"}]


def _core_error(model, requirements: dict) -> tuple[str, str]:
    with pytest.raises(ValidationError) as exc:
        model.model_validate(requirements)
    e = from_validation(exc.value)
    return e.field, e.rule


def _http_error(client, url: str, device: dict, requirements: dict, part: str = "requirements",
                **extra) -> tuple[str, str]:
    r = client.post(url, json={"device": device, part: requirements, **extra})
    assert r.status_code == 422, r.text
    e = r.json()["detail"][0]
    assert e["loc"][:2] == ["body", part], e
    return ".".join(str(p) for p in e["loc"][2:]), e["msg"]


@pytest.mark.parametrize("requirements", STIFFNESS_BAD)
def test_stiffness_422_is_optims_rule_and_message(client, requirements):
    assert _http_error(client, "/v1/design/stiffness", LHIFAM_RIGID, requirements) == \
        _core_error(StiffnessRequirements, requirements)


@pytest.mark.parametrize("requirements", INERTIA_BAD)
def test_inertia_422_is_optims_rule_and_message(client, requirements):
    assert _http_error(client, "/v1/design/inertia", {"preset": "lhifam"}, requirements) == \
        _core_error(InertiaRequirements, requirements)


HARDWARE_BAD = [{}, {"stiffness": 0}, {"stiffness": 2e5, "min_gain_margin_db": 121}, {"force_gain": 5, "apparent_mass": 1},
                {"force_gain": 5, "max_damping": 10}, {"stiffness": 2e5, "cutoff_min_hz": 20},
                {"force_gain": 5, "filter_order": 7}, {"apparent_mass": 1e13}]


@pytest.mark.parametrize("target", HARDWARE_BAD)
def test_hardware_target_422_is_optims_rule_and_message(client, target):
    assert _http_error(client, "/v1/design/hardware", LHIFAM_RIGID, target, "target", free="delay") == \
        _core_error(HardwareTarget, target)


def test_a_rule_changed_in_optim_shows_in_the_422(client, monkeypatch):
    """The pairing rule's text lives in optim.stiffness.requirements alone: change it there, the answer follows."""
    changed = tuple((a, b, f"{rule} [changed in optim]") for a, b, rule in stiffness_requirements._PAIRS)
    monkeypatch.setattr(stiffness_requirements, "_PAIRS", changed)
    field, msg = _http_error(client, "/v1/design/stiffness", LHIFAM_RIGID, {"max_force": 3})
    assert field == "max_penetration" and msg == "required when max_force is given (K·x ≤ F [changed in optim])"


def test_the_numerics_take_the_validated_requirements(client):
    """The route hands optim a plain optim model (the box goes separately): equal to one built by optim."""
    req = StiffnessRequirementsIn.model_validate({"max_force": 30, "max_penetration": 0.01, "uncertainty": None})
    assert type(req.core()) is StiffnessRequirements
    assert req.core() == StiffnessRequirements(max_force=30, max_penetration=0.01)
    spec = InertiaRequirementsIn.model_validate({"humans": [HUMAN], "filter_order": 3}, strict=True).core()
    assert type(spec) is InertiaRequirements and spec == InertiaRequirements(humans=[HUMAN], filter_order=3)


@pytest.mark.parametrize("bad", [True, "5.4"])
def test_strict_numbers_reach_the_nested_requirements(client, bad):
    """JSON numbers only, at every depth of the inertia requirements (the grasps and the mass range too)."""
    for requirements, loc in (({"humans": [{**HUMAN, "mass": bad}]}, ["humans", 0, "mass"]),
                              ({"human_mass_range": {"min": bad, "max": 2}}, ["human_mass_range", "min"])):
        r = client.post("/v1/design/inertia", json={"device": {"preset": "lhifam"}, "requirements": requirements})
        assert r.status_code == 422 and r.json()["detail"][0]["loc"] == ["body", "requirements", *loc], r.text


@pytest.mark.parametrize("url, device", [("/v1/analysis/stability", LHIFAM_RIGID), ("/v1/design/stiffness", LHIFAM_RIGID),
                                         ("/v1/analysis/force-feedforward", {"preset": "lhifam"}),
                                         ("/v1/design/inertia", {"preset": "lhifam"})])
@pytest.mark.parametrize("field, value", [("method", "fast"), ("grid_points", 9), ("grid_points", 10**6 + 1)])
def test_the_ladder_rule_is_one_rule(client, url, device, field, value):
    """The rung and its grid size: optim.stability.analysis.check_rung (for direct callers) and every request
    field answer the same rule with the same message."""
    rung = {"method": "grid", "grid_points": 1000, field: value}
    with pytest.raises(InputError) as exc:
        check_rung(rung["method"], rung["grid_points"])
    r = client.post(url, json={"device": device, **rung})
    assert r.status_code == 422, r.text
    (e,) = r.json()["detail"]
    assert (e["loc"], e["msg"]) == (["body", exc.value.field], exc.value.rule)
