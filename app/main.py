"""The FastAPI application: ``create_app(settings)`` wires routes, limits, logs and error bodies.

Nothing heavy happens at import: the ontology and the session store are built in ``lifespan`` and
reached through ``app.api.deps`` (STYLE.md §5).
"""

from __future__ import annotations

import logging
import time
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager

from fastapi import FastAPI

from app.api.routes import health, sessions, steps, teach
from app.body_limit import BodySizeLimit
from app.error_handlers import install_error_handlers
from app.logging_json import configure_json_logging
from app.request_log import RequestLog
from app.settings import Settings
from app.store import InMemorySessionStore
from app.teach import START_EDH_PATH, TeachEpisodes
from app.version import service_version
from symbolic.ontology import load_ontology

_LOG = logging.getLogger("app")

DESCRIPTION = """\
A neuro-symbolic conversational embodied agent (JARVIS planning and commonsense repair, HLSM-style
spatial memory) for TEACh (EDH, TfD, TATC) and ALFRED. Create a session, send each egocentric
observation to its step route, execute the returned action. Every error is `{"error", "detail"}`.
"""


def create_app(settings: Settings | None = None, *, clock: Callable[[], float] = time.monotonic) -> FastAPI:
    """The service. ``clock`` (seconds, monotonic) drives session idle expiry; tests pass a fake one."""
    settings = settings or Settings()
    configure_json_logging(settings.log_level)

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        if settings.torch_threads is not None:
            _limit_torch_threads(settings.torch_threads)
        app.state.ontology = load_ontology()
        app.state.store = InMemorySessionStore(settings.max_sessions, settings.session_ttl_s, clock=clock)
        app.state.teach_episodes = TeachEpisodes()
        _LOG.info(
            "service_ready", extra={"version": app.version, "object_types": len(app.state.ontology.types)}
        )
        yield
        _LOG.info("service_stopping", extra={"sessions": len(app.state.store)})
        app.state.store = None
        app.state.teach_episodes = None
        app.state.ontology = None

    app = FastAPI(
        title="JARVIS embodied agent service",
        version=service_version(),
        description=DESCRIPTION,
        lifespan=lifespan,
    )
    app.state.settings = settings
    app.include_router(health.router)
    app.include_router(sessions.router)
    app.include_router(steps.router)
    app.include_router(teach.router)
    install_error_handlers(app)
    # The last middleware added runs first: log every request, including bodies refused for size.
    app.add_middleware(
        BodySizeLimit,
        max_body_bytes=settings.max_body_bytes,
        path_limits={START_EDH_PATH: (settings.max_edh_body_bytes, "JARVIS_MAX_EDH_BODY_BYTES")},
    )
    app.add_middleware(RequestLog)
    return app


def _limit_torch_threads(threads: int) -> None:
    """The networks' intra-op pool size; torch applies it to every thread started afterwards, which
    includes the worker threads requests run in."""
    import torch

    torch.set_num_threads(threads)
