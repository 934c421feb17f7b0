"""``Annotated`` dependency aliases: how a handler gets settings, the store, the ontology and its session.

Everything comes from ``app.state``, filled by the lifespan (nothing heavy at import, STYLE.md §5).
They are ``async def`` although none awaits: each is a lookup under at most a brief lock, and FastAPI runs a
plain ``def`` dependency in the worker-thread pool, one thread hop each (four per step: about 1.5 ms of a
25 ms step, `bench/step_latency.py`).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Annotated, cast

from fastapi import Depends, Request

from agent.session import AgentSession
from app.errors import NOT_READY, SESSION_NOT_FOUND, STEP_IN_PROGRESS, ApiError
from app.settings import Settings
from app.store import SessionBusy, SessionNotFound, SessionStore
from app.teach import TeachEpisodes, TeachForm, read_teach_form
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


async def get_teach_episodes(request: Request) -> TeachEpisodes:
    episodes = getattr(request.app.state, "teach_episodes", None)
    if episodes is None:
        raise ApiError(503, NOT_READY, "the TEACh episode index is not loaded yet (the service is starting)")
    return cast(TeachEpisodes, episodes)


SettingsDep = Annotated[Settings, Depends(get_settings)]
StoreDep = Annotated[SessionStore, Depends(get_store)]
OntologyDep = Annotated[Ontology, Depends(get_ontology)]
TeachEpisodesDep = Annotated[TeachEpisodes, Depends(get_teach_episodes)]


async def get_teach_form(request: Request, settings: SettingsDep) -> TeachForm:
    """The TEACh request's form fields and files (``app.teach.read_teach_form``)."""
    return await read_teach_form(request, settings)


TeachFormDep = Annotated[TeachForm, Depends(get_teach_form)]


def session_not_found(session_id: str) -> ApiError:
    return ApiError(
        404,
        SESSION_NOT_FOUND,
        f"no session {session_id!r} (never created, deleted, or evicted after being idle past the TTL)",
    )


@dataclass(frozen=True)
class SessionHandle:
    """A session known to exist when the handler starts; ``hold()`` gives exclusive use of it."""

    session_id: str
    store: SessionStore
    lock_timeout_s: float  # seconds to wait for a busy session before 409

    @contextmanager
    def hold(self) -> Iterator[AgentSession]:
        """The session, locked against other requests while the block runs (never interleaved, §4)."""
        try:
            with self.store.hold(self.session_id, self.lock_timeout_s) as session:
                yield session
        except SessionNotFound as error:
            raise session_not_found(self.session_id) from error
        except SessionBusy as error:
            raise ApiError(
                409,
                STEP_IN_PROGRESS,
                f"session {self.session_id!r} is busy with another request for over {self.lock_timeout_s} s; "
                "retry when it has answered",
            ) from error


async def get_session(session_id: str, store: StoreDep, settings: SettingsDep) -> SessionHandle:
    """404 ``session_not_found`` unless the session is live; using it restarts its idle TTL."""
    try:
        store.touch(session_id)
    except SessionNotFound as error:
        raise session_not_found(session_id) from error
    return SessionHandle(session_id=session_id, store=store, lock_timeout_s=settings.session_lock_timeout_s)


SessionDep = Annotated[SessionHandle, Depends(get_session)]
