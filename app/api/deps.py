"""``Annotated`` dependency aliases: how a handler gets settings, the store, the ontology, its caller and its
session.

Everything comes from ``app.state``, filled by the lifespan (nothing heavy at import, STYLE.md §5), and the
caller from ``app.access.KeyCheck``. They are ``async def`` although none awaits: each is a lookup, and
FastAPI runs a
plain ``def`` dependency in the worker-thread pool, one thread hop each (four per step: about 1.5 ms of a
25 ms step, `bench/step_latency.py`).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Annotated, cast

from fastapi import Depends, Request

from app.access import CALLER_STATE
from app.errors import NOT_READY, ApiError
from app.live_view import SessionView
from app.ownership import Caller
from app.settings import Settings
from app.store import SessionNotFound, SessionStore, StoredSession
from app.store_errors import session_not_found, store_errors_as_api_errors
from app.teach import TeachForm, read_teach_form
from symbolic.ontology import Ontology


async def get_settings(request: Request) -> Settings:
    return cast(Settings, request.app.state.settings)


async def get_store(request: Request) -> SessionStore:
    store = getattr(request.app.state, "store", None)
    if store is None:
        raise ApiError(503, NOT_READY, "the session store is not loaded yet (the service is starting)")
    return cast(SessionStore, store)


async def get_ontology(request: Request) -> Ontology:
    ontology = getattr(request.app.state, "ontology", None)
    if ontology is None:
        raise ApiError(503, NOT_READY, "the ontology is not loaded yet (the service is starting)")
    return cast(Ontology, ontology)


SettingsDep = Annotated[Settings, Depends(get_settings)]
StoreDep = Annotated[SessionStore, Depends(get_store)]
OntologyDep = Annotated[Ontology, Depends(get_ontology)]


async def get_teach_form(request: Request, settings: SettingsDep) -> TeachForm:
    """The TEACh request's form fields and files (``app.teach.read_teach_form``)."""
    return await read_teach_form(request, settings)


TeachFormDep = Annotated[TeachForm, Depends(get_teach_form)]


async def get_caller(request: Request) -> Caller:
    """Who calls, as ``app.access.KeyCheck`` found it before the body was read (owner None when open)."""
    caller = request.scope.get("state", {}).get(CALLER_STATE)
    if not isinstance(caller, Caller):
        raise ApiError(503, NOT_READY, "the caller was not identified (the key check is not installed)")
    return caller


CallerDep = Annotated[Caller, Depends(get_caller)]


@dataclass(frozen=True)
class SessionHandle:
    """A session of the caller's; ``hold()`` gives exclusive use of it."""

    session_id: str
    owner: str | None
    store: SessionStore
    lock_timeout_s: float  # seconds to wait for a busy session before 409

    @contextmanager
    def hold(self, *, write: bool = False) -> Iterator[StoredSession]:
        """The session, locked against other requests while the block runs (never interleaved, §4); with
        ``write`` the store keeps what the block left (a durable store writes its snapshot before the
        answer)."""
        with (
            store_errors_as_api_errors(self.session_id, self.lock_timeout_s),
            self.store.hold(self.session_id, self.owner, self.lock_timeout_s, write=write) as stored,
        ):
            yield stored


async def get_session(
    session_id: str, store: StoreDep, settings: SettingsDep, caller: CallerDep
) -> SessionHandle:
    return SessionHandle(
        session_id=session_id,
        owner=caller.owner,
        store=store,
        lock_timeout_s=settings.session_lock_timeout_s,
    )


SessionDep = Annotated[SessionHandle, Depends(get_session)]


async def get_view(session_id: str, store: StoreDep, caller: CallerDep) -> SessionView:
    """The caller's session as its last completed change left it, without waiting for a step in progress
    (``app.live_view``); reading counts as use (restarts the idle TTL)."""
    try:
        return await store.view(session_id, caller.owner, touch=True)
    except SessionNotFound as error:
        raise session_not_found(session_id) from error


ViewDep = Annotated[SessionView, Depends(get_view)]
