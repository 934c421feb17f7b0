"""``/v1/sessions``: create, read, delete a session and add utterances (DESIGN.md §4).

Reads (the session, its trace, its map) are served from the view the last completed change published
(``app.live_view``): they never wait on, nor are refused by, a step in progress.
"""

from __future__ import annotations

import logging
import uuid
from datetime import UTC, datetime
from typing import Annotated

import anyio.to_thread
from fastapi import APIRouter, Query, Response

from app.api.deps import CallerDep, OntologyDep, SessionDep, SettingsDep, StoreDep, ViewDep
from app.api.responses import error_responses
from app.limits import check_dialogue
from app.ownership import owner_cap, too_many_sessions
from app.schemas import SessionCreate, SessionList, SessionPublic, UtteranceCreate, UtteranceResult
from app.session_builder import build_session, planning_errors_as_api_errors
from app.store import SessionNotFound, StoredSession, StoreFull
from app.store_errors import session_not_found
from app.views import session_public

router = APIRouter(prefix="/v1/sessions", tags=["sessions"])
TRACE_MEDIA_TYPE = "application/x-ndjson"
_LOG = logging.getLogger("app.sessions")


@router.post(
    "",
    status_code=201,
    response_model=SessionPublic,
    responses=error_responses(400, 401, 413, 422, 429, 503),
    summary="Create a session and its first repaired plan",
)
def create_session(
    body: SessionCreate,
    settings: SettingsDep,
    store: StoreDep,
    ontology: OntologyDep,
    caller: CallerDep,
    response: Response,
) -> SessionPublic:
    session = build_session(body, settings, ontology, session_id=uuid.uuid4().hex, now=datetime.now(UTC))
    try:
        store.create(StoredSession(session, caller.owner), owner_cap=owner_cap(caller, settings))
    except StoreFull as error:
        raise too_many_sessions(error, settings) from error
    response.headers["Location"] = f"/v1/sessions/{session.session_id}"
    _LOG.info(
        "session_created",
        extra={
            "session_id": session.session_id,
            "mode": session.spec.mode,
            "planner": session.planner.name,
            "plan_length": len(session.plan),
            "repairs": len(session.repair_log),
        },
    )
    return session_public(session)


@router.get(
    "",
    response_model=SessionList,
    responses=error_responses(401, 429, 503),
    summary="List the caller's live sessions, oldest first",
)
def list_sessions(store: StoreDep, caller: CallerDep) -> SessionList:
    return SessionList(session_ids=store.ids(caller.owner))


@router.get(
    "/{session_id}",
    response_model=SessionPublic,
    responses=error_responses(401, 404, 422, 429, 503),
    summary="Read a session: configuration, dialogue, plan and progress",
)
async def read_session(view: ViewDep) -> Response:
    return Response(content=view.public_json, media_type="application/json")


@router.delete(
    "/{session_id}",
    status_code=204,
    response_class=Response,
    responses=error_responses(401, 404, 422, 429, 503),
    summary="Delete a session and free its slot",
)
def delete_session(session_id: str, store: StoreDep, caller: CallerDep) -> Response:
    try:
        store.delete(session_id, caller.owner)
    except SessionNotFound as error:
        raise session_not_found(session_id) from error
    _LOG.info("session_deleted", extra={"session_id": session_id})
    return Response(status_code=204)


@router.post(
    "/{session_id}/utterances",
    response_model=UtteranceResult,
    responses=error_responses(400, 401, 404, 409, 410, 413, 422, 429, 503),
    summary="Add a dialogue turn; a commander turn may re-plan",
)
def add_utterance(body: UtteranceCreate, handle: SessionDep, settings: SettingsDep) -> UtteranceResult:
    with handle.hold(write=True) as held:
        session = held.session
        check_dialogue([body], settings, already=len(session.dialogue))
        speaker = body.normalized_speaker()
        with planning_errors_as_api_errors("dialogue"):
            replanned = session.add_utterance(speaker, body.text)
        if replanned:
            note = "the commander's turn produced a new plan; the pointer restarts at its first subgoal"
        elif speaker != "Commander":
            note = "recorded; only commander turns can change the plan"
        else:
            note = (
                f"recorded; planner {session.planner.name!r} follows the subgoals it was given and does not "
                "re-plan from dialogue"
            )
        return UtteranceResult(session=session_public(session), replanned=replanned, note=note)


@router.get(
    "/{session_id}/trace",
    response_class=Response,
    responses={
        200: {
            "description": "One JSON object per step (ndjson): inputs, success verdict, pose, map "
            "statistics, subgoal, action and the predicate or rule that chose it, server timings.",
            "content": {TRACE_MEDIA_TYPE: {"schema": {"type": "string"}}},
        },
        **error_responses(401, 404, 422, 429, 503),
    },
    summary="Read the step trace as ndjson (one line per step)",
)
async def read_trace(
    session_id: str,
    store: StoreDep,
    caller: CallerDep,
    since: Annotated[int | None, Query(ge=0, description="Only steps from this index on.")] = None,
) -> Response:
    try:
        lines = await store.trace_lines(session_id, caller.owner, since)
    except SessionNotFound as error:
        raise session_not_found(session_id) from error
    body = "".join(f"{line}\n" for line in lines)
    return Response(content=body, media_type=TRACE_MEDIA_TYPE)


@router.get(
    "/{session_id}/map.png",
    response_class=Response,
    responses={
        200: {
            "description": "The semantic map from above: free floor, obstacles, unexplored space, each "
            "object class in its colour, the agent, its planned path, the current target, and a legend.",
            "content": {"image/png": {"schema": {"type": "string", "format": "binary"}}},
        },
        **error_responses(401, 404, 422, 429, 503),
    },
    summary="Draw the session's semantic map as a PNG",
)
async def read_map(view: ViewDep) -> Response:
    # Drawn once per view (about 6 ms): off the event loop the first time.
    picture = view.map_png() if view.map_drawn else await anyio.to_thread.run_sync(view.map_png)
    return Response(content=picture, media_type="image/png")
