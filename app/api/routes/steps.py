"""``POST /v1/sessions/{id}/step``: one observation in, the next action out (DESIGN.md §3-4).

The request is validated completely (images decoded and checked against the session's camera, the
step index against the session's progress) under the session's lock. The executor that turns it into
an action (perception, map, navigation; JARVIS Algorithm 3) arrives with the agent issue; until then a
valid request is answered 501 and the session is not changed. A multipart form of this route (images
as file parts) will feed the same ``decode_observation`` with the parts' bytes.
"""

from __future__ import annotations

from fastapi import APIRouter

from app.api.deps import OntologyDep, SessionDep
from app.api.responses import error_responses
from app.errors import NOT_IMPLEMENTED, STEP_OUT_OF_ORDER, ApiError
from app.observation import decode_observation
from app.schemas import StepRequest, StepResult

router = APIRouter(prefix="/v1/sessions", tags=["steps"])


@router.post(
    "/{session_id}/step",
    response_model=StepResult,
    responses=error_responses(400, 404, 409, 413, 422, 501, 503),
    summary="Send one observation and receive the next action",
)
def step(body: StepRequest, handle: SessionDep, ontology: OntologyDep) -> StepResult:
    with handle.hold() as session:
        if body.step is not None and body.step != session.step:
            raise ApiError(
                409,
                STEP_OUT_OF_ORDER,
                f"step {body.step} was sent but session {session.session_id!r} expects step {session.step}",
            )
        decode_observation(body, session.camera, session.perception, ontology)
        raise ApiError(
            501,
            NOT_IMPLEMENTED,
            "the observation is valid, but the executor (perception -> map -> navigation -> action, "
            "DESIGN.md §3) arrives with the agent issue; the session was not changed",
        )
