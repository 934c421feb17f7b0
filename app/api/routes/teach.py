"""TEACh's RemoteModel routes (DESIGN.md §4): ``/start_new_edh_instance``, ``/get_next_action``, ``/test``,
``/ping``. Thin: the form is read by ``TeachFormDep`` and the protocol lives in ``app.teach``."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter

from app.api.deps import CallerDep, OntologyDep, SettingsDep, StoreDep, TeachFormDep
from app.api.responses import error_responses
from app.metrics import MetricsDep
from app.schemas import TeachAction, TeachStarted, TeachStatus
from app.teach import HISTORY_FIELD, START_EDH_PATH, next_action, start_edh_instance
from app.version import service_version

router = APIRouter(tags=["teach"])


def _form_doc(properties: dict[str, Any], required: list[str]) -> dict[str, Any]:
    schema = {"type": "object", "properties": properties, "required": required}
    return {
        "requestBody": {
            "required": True,
            "content": {"multipart/form-data": {"schema": schema}},
        }
    }


_JSON_TEXT = {"type": "string", "description": "JSON text"}
_START_DOC = _form_doc(
    {
        "edh_name": {"type": "string", "description": "The instance's name (TEACh sends its file path)."},
        "edh_instance": {**_JSON_TEXT, "description": "The TEACh EDH instance as JSON text."},
        HISTORY_FIELD: {
            "type": "array",
            "items": {"type": "string", "format": "binary"},
            "description": "One JPEG per driver_action_history entry: the view before it.",
        },
    },
    ["edh_instance"],
)
_NEXT_DOC = _form_doc(
    {
        "edh_name": {"type": "string", "description": "The name the instance was started with."},
        "img_name": {"type": "string", "description": "The frame's name; a repeated one is a retry."},
        "prev_action": {
            **_JSON_TEXT,
            "description": 'The last answer as executed: {"action", "obj_relative_coord"}; absent or empty '
            "on the first step.",
        },
        "edh_instance": {
            **_JSON_TEXT,
            "description": "The TEACh EDH instance (RemoteModel sends it each step).",
        },
        "img": {"type": "string", "format": "binary", "description": "The current frame, JPEG."},
    },
    ["img"],
)


@router.post(
    START_EDH_PATH,
    response_model=TeachStarted,
    responses=error_responses(400, 401, 413, 415, 422, 429, 503),
    summary="TEACh: start an EDH instance (its session replays the history)",
    openapi_extra=_START_DOC,
)
def start_new_edh_instance(
    form: TeachFormDep,
    settings: SettingsDep,
    store: StoreDep,
    ontology: OntologyDep,
    caller: CallerDep,
) -> TeachStarted:
    return start_edh_instance(form, settings, store, ontology, caller)


@router.post(
    "/get_next_action",
    response_model=TeachAction,
    responses=error_responses(400, 401, 404, 409, 410, 413, 415, 422, 429, 503),
    summary="TEACh: the next action for a frame, click point row first",
    openapi_extra=_NEXT_DOC,
)
def get_next_action(
    form: TeachFormDep,
    settings: SettingsDep,
    store: StoreDep,
    ontology: OntologyDep,
    caller: CallerDep,
    metrics: MetricsDep,
) -> TeachAction:
    return next_action(form, settings, store, ontology, caller, metrics)


@router.get(
    "/test", response_model=TeachStatus, summary="TEACh: connection check (RemoteModel.test_connection)"
)
def test() -> TeachStatus:
    return TeachStatus(status="ok", version=service_version())


@router.get("/ping", response_model=TeachStatus, summary="TEACh: liveness")
def ping() -> TeachStatus:
    return TeachStatus(status="ok", version=service_version())
