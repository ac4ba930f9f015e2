"""The answers this client parses, as its own pydantic models: the client never imports the server.

Generated once from the service's ``/openapi.json`` with datamodel-code-generator (not a dependency of
zwidth), keeping only the response models and the types nested in them, one module per area
(``scripts/client_schemas.py`` does both steps):

    datamodel-codegen --input openapi.json --input-file-type openapi \\
        --output-model-type pydantic_v2.BaseModel --target-python-version 3.11 --use-annotated \\
        --use-double-quotes --enum-field-as-literal all --base-class clients.schemas.answer.Answer --treat-dot-as-module \\
        --disable-timestamp --use-schema-description --strict-nullable --output clients/schemas

with the components renamed ``<module>.<Name>`` and the input rules (bounds, lengths, patterns, property
titles) dropped before generating: the server has already validated what it sends, and an older client
must read a newer server's answers.  For the same reason every model derives from
:class:`~clients.schemas.answer.Answer` (``extra="allow"``): a field the server adds later is kept (and
shown by ``--json``), not refused.  Three edits after generating: black
at 120 columns; ``Cable.natural_frequency`` (eq. 24, shown by the presets table); and the list and map
fields that the server fills with an empty default (a default the schema does not show) given
``default_factory`` instead of the generator's ``| None = None``.

``tests/clients/test_client_schemas.py`` holds these models against ``/openapi.json`` of the current
app: the same field names, the same required and nullable fields, recursively.  A field added on the
server without the client fails that test by name; regenerate (or edit the model) and commit.
"""

from .analysis import BoundaryPointOut, BoundaryResponse, ForceCrossoverOut, ForceFeedforwardResponse, StabilityResponse
from .common import CrossoverOut, HumanOut, PassivityVerificationOut, VerificationOut
from .design import HardwareDesignResponse, InertiaResponse, StiffnessDesignResponse
from .device import Cable, Device, ForceSensor, Human
from .health import ComputeQueue, Health, Readiness
from .identify import IdentifyResponse
from .simulate import SimulateResponse
from .studies import StudyCreated, StudyList, StudyResults, StudyStatus
from .workspace import WorkspacePointOut, WorkspaceResponse

#: Every response model the client parses, by the name of its component in /openapi.json.
RESPONSES = {m.__name__: m for m in (
    StabilityResponse, BoundaryResponse, ForceFeedforwardResponse, StiffnessDesignResponse, InertiaResponse,
    HardwareDesignResponse, SimulateResponse, IdentifyResponse, StudyCreated, StudyList, StudyResults,
    StudyStatus, Health, Readiness, Device, WorkspaceResponse)}

__all__ = [
    "RESPONSES",
    "WorkspacePointOut",
    "WorkspaceResponse",
    "BoundaryPointOut",
    "BoundaryResponse",
    "ForceCrossoverOut",
    "ForceFeedforwardResponse",
    "StabilityResponse",
    "CrossoverOut",
    "HumanOut",
    "PassivityVerificationOut",
    "VerificationOut",
    "HardwareDesignResponse",
    "InertiaResponse",
    "StiffnessDesignResponse",
    "Cable",
    "Device",
    "ForceSensor",
    "Human",
    "ComputeQueue",
    "Health",
    "Readiness",
    "IdentifyResponse",
    "SimulateResponse",
    "StudyCreated",
    "StudyList",
    "StudyResults",
    "StudyStatus",
]
