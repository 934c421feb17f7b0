"""``POST /v1/sessions/{id}/step``: one observation in, the next action out (DESIGN.md §3-4).

The body is a ``StepRequest`` as JSON (images base64) or as multipart/form-data with the same field names
(images as file parts, ``pose`` and ``segmentation_legend`` as JSON text). Under the session's lock: a
``step`` equal to the last answered step returns that answer again unchanged (a lost response can be
retried safely); any other mismatch is 409. The observation is decoded and checked completely, and
perception runs, before the session changes, so a refused step leaves it exactly as it was.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Coroutine
from typing import Any

import anyio
import orjson
from fastapi import APIRouter, Request, Response
from fastapi.routing import APIRoute

from agent.session import AgentSession
from app.api.deps import OntologyDep, SessionDep
from app.api.responses import error_responses
from app.deadline import refuse_stale_request
from app.errors import STEP_OUT_OF_ORDER, VALIDATION_ERROR, ApiError
from app.metrics import MetricsDep
from app.multipart import parse_form
from app.observation import observation_from_request
from app.schemas import StepRequest, StepResult
from app.step_run import StepRules, run_step
from app.views import step_result

IMAGE_FIELDS: tuple[str, ...] = ("rgb", "depth", "depth_uncertainty", "segmentation")
"""StepRequest fields that may arrive as multipart file parts."""
JSON_TEXT_FIELDS: frozenset[str] = frozenset(
    {"pose", "segmentation_legend", "segmentation_ids_persistent", "last_action_success", "step"}
)
"""Multipart text fields that carry JSON (objects, booleans, integers) rather than plain text."""
PROCESS_TIME_HEADER = "X-Process-Time-Ms"
"""Server-side milliseconds spent on the step, from the parsed request to the answer."""

_MULTIPART_DOC: dict[str, Any] = {
    "requestBody": {
        "content": {
            "multipart/form-data": {
                "schema": {
                    "type": "object",
                    "description": "The StepRequest fields as form fields; images may be file parts "
                    "(raw PNG/JPEG, 16-bit PNG, float32 bytes, or .npy arrays: uint8 [H, W, 3] RGB, "
                    "integer [H, W] ids, float32 [H, W] metres), pose and segmentation_legend JSON text.",
                    "properties": {
                        **{name: {"type": "string", "format": "binary"} for name in IMAGE_FIELDS},
                        "depth_encoding": {"type": "string", "enum": ["png16_mm", "float32_m"]},
                        "segmentation_legend": {"type": "string", "description": 'JSON {"7": "Knife"}'},
                        "segmentation_ids_persistent": {"type": "string", "enum": ["true", "false"]},
                        "pose": {"type": "string", "description": "JSON Pose"},
                        "last_action_success": {"type": "string", "enum": ["true", "false"]},
                        "step": {"type": "integer"},
                        "held_object": {"type": "string"},
                    },
                }
            }
        }
    }
}


class _OrjsonRequest(Request):
    """A request whose JSON body orjson parses: a step's body is about 230 kB, mostly base64 images, which
    the standard library parses in 0.55 ms and orjson in 0.13 ms. What orjson refuses goes to the standard
    library, so the service reads exactly what it did: a ``NaN`` (Python's ``json.dumps`` writes them) is
    still a 422 naming its field, malformed text still a 400 ``malformed_json`` naming the byte."""

    async def json(self) -> Any:
        if not hasattr(self, "_json"):
            body = await self.body()
            try:
                self._json = orjson.loads(body)
            except orjson.JSONDecodeError:
                self._json = json.loads(body)
        return self._json


class JsonOrFormRoute(APIRoute):
    """A route whose JSON body may also come as multipart/form-data.

    The form's text fields become the JSON body FastAPI validates as usual (so errors look the same);
    its file parts are kept as bytes in ``request.state.step_parts`` and decoded without base64.
    """

    def get_route_handler(self) -> Callable[[Request], Coroutine[Any, Any, Response]]:
        handle_json = super().get_route_handler()

        async def handle(request: Request) -> Response:
            if request.headers.get("content-type", "").startswith("multipart/form-data"):
                request = await _form_as_json(request)
            return await handle_json(_OrjsonRequest(request.scope, request.receive))

        return handle


async def _form_as_json(request: Request) -> Request:
    """The same request with its form's text fields as a JSON body and its file parts in the state."""
    form = parse_form(await request.body(), request.headers.get("content-type", ""))
    fields: dict[str, Any] = {}
    for name, value in form.texts.items():
        if name in JSON_TEXT_FIELDS:
            try:
                fields[name] = json.loads(value)
            except json.JSONDecodeError:
                fields[name] = value  # validation names the field and the bad text
        else:
            fields[name] = value
    parts = form.files
    body = json.dumps(fields).encode()
    headers = [(k, v) for k, v in request.scope["headers"] if k not in (b"content-type", b"content-length")]
    headers += [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode())]
    scope = {**request.scope, "headers": headers}
    scope.setdefault("state", {})["step_parts"] = parts
    sent = False

    async def receive() -> dict[str, Any]:
        nonlocal sent
        if sent:
            return {"type": "http.disconnect"}
        sent = True
        return {"type": "http.request", "body": body, "more_body": False}

    return Request(scope, receive)


router = APIRouter(prefix="/v1/sessions", tags=["steps"], route_class=JsonOrFormRoute)


@router.post(
    "/{session_id}/step",
    response_model=StepResult,
    responses=error_responses(400, 401, 404, 409, 410, 413, 422, 429, 503),
    summary="Send one observation (JSON or multipart) and receive the next action",
    openapi_extra=_MULTIPART_DOC,
)
async def step(
    body: StepRequest,
    request: Request,
    response: Response,
    handle: SessionDep,
    ontology: OntologyDep,
    metrics: MetricsDep,
) -> StepResult:
    parts: dict[str, bytes] = getattr(request.state, "step_parts", {})
    unknown = set(parts) - set(IMAGE_FIELDS)
    if unknown:
        raise ApiError(
            422,
            VALIDATION_ERROR,
            f"{', '.join(sorted(unknown))}: only {', '.join(IMAGE_FIELDS)} may be file parts",
        )

    def check_order(session: AgentSession) -> None:
        if body.step is not None and body.step != session.step:
            last = session.last_decision
            again = f" (or {last.step} again, to repeat the last answer)" if last is not None else ""
            raise ApiError(
                409,
                STEP_OUT_OF_ORDER,
                f"step {body.step} was sent but session {session.session_id!r} expects step "
                f"{session.step}{again}",
            )

    rules = StepRules(
        repeats_last=lambda _, last: body.step is not None and body.step == last.step,
        check_order=check_order,
        observe=lambda session: observation_from_request(
            body, session.spec.camera, session.spec.perception, ontology, parts
        ),
    )

    def work() -> tuple[StepResult, float]:
        """The step in one worker thread: the queue deadline, then ``run_step`` under the session's lock."""
        refuse_stale_request(request)  # what the other routes' dependency checks, once a thread is free
        started = time.perf_counter()
        with handle.hold(write=True) as held:
            answer = step_result(run_step(held, rules, metrics).decision)
        return answer, (time.perf_counter() - started) * 1e3

    # One thread hop per step: FastAPI would take three for a synchronous handler (the deadline
    # dependency, the handler, the response's validation), about half a millisecond of a 10 ms step.
    answer, process_ms = await anyio.to_thread.run_sync(work)
    response.headers[PROCESS_TIME_HEADER] = f"{process_ms:.3f}"
    return answer
