"""The FastAPI application: ``create_app(settings)`` wires routes, limits, logs and error bodies.

Nothing heavy happens at import: the ontology and the session store are built in ``lifespan`` and
reached through ``app.api.deps`` (STYLE.md §5).
"""

from __future__ import annotations

import logging
import os
import sys
import time
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager

import anyio.to_thread
import cv2
import redis
from fastapi import Depends, FastAPI

from agent.planning import make_planner
from app.access import KeyCheck
from app.api.routes import health, live, metrics, sessions, steps, teach
from app.api_docs import install_api_docs
from app.body_limit import BodySizeLimit
from app.deadline import refuse_stale_request
from app.error_handlers import install_error_handlers
from app.keys import KeyRing
from app.logging_json import configure_json_logging
from app.metrics import ServiceMetrics
from app.preload import ModelPreload
from app.rate_limit import InMemoryRateLimiter, RateLimiter, RedisRateLimiter
from app.recycle import ConnectionRecycling
from app.redis_store import RedisSessionStore, SnapshotObserver
from app.request_log import RequestLog
from app.session_builder import network_paths, planner_config
from app.settings import Settings
from app.store import InMemorySessionStore, SessionStore
from app.teach import START_EDH_PATH
from app.version import service_version
from symbolic.ontology import Ontology, load_ontology

_LOG = logging.getLogger("app")

DESCRIPTION = """\
A neuro-symbolic conversational embodied agent (JARVIS planning and commonsense repair, HLSM-style
spatial memory) for TEACh (EDH, TfD, TATC) and ALFRED. Create a session, send each egocentric
observation to its step route, execute the returned action. Every error is `{"error", "detail"}`.
"""


PRELOAD_SHUTDOWN_WAIT_S = 120.0
"""Seconds a stopping service waits for the model preload to finish: the ONNX export and ONNX Runtime run
native threads, and a process that exits while they work aborts (std::terminate) instead of stopping. A
load takes a few seconds; after the first in a process, none."""


def create_app(settings: Settings | None = None, *, clock: Callable[[], float] = time.monotonic) -> FastAPI:
    """The service. ``clock`` (seconds, monotonic) drives session idle expiry; tests pass a fake one."""
    settings = settings or Settings()
    configure_json_logging(settings.log_level)

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        limit_threads(settings.threads_per_worker)
        anyio.to_thread.current_default_thread_limiter().total_tokens = settings.concurrent_requests
        app.state.ontology = load_ontology()
        app.state.keys = KeyRing.configured(settings.api_keys, settings.api_keys_file)
        app.state.store, app.state.rate_limiter = build_store(
            settings, app.state.ontology, clock, on_snapshot=app.state.metrics.observe_snapshot
        )
        _log_access_mode(settings, app.state.keys)
        # The models sessions need load in the background; /readyz says 503 until they are in (app.preload).
        app.state.model_preload = ModelPreload.for_settings(settings) if settings.preload_models else None
        if app.state.model_preload is not None:
            app.state.model_preload.start()
        _LOG.info(
            "service_ready", extra={"version": app.version, "object_types": len(app.state.ontology.types)}
        )
        yield
        try:
            _LOG.info("service_stopping", extra={"sessions": len(app.state.store)})
        except redis.RedisError:  # the store went away first: stop all the same
            _LOG.info("service_stopping", extra={"sessions": None})
        preload = app.state.model_preload
        if preload is not None and not preload.wait(PRELOAD_SHUTDOWN_WAIT_S):
            _LOG.warning("model_preload_unfinished", extra={"pending": preload.pending()})
        await app.state.store.close_readers()
        app.state.store.close()
        app.state.rate_limiter.close()
        app.state.store = None
        app.state.rate_limiter = None
        app.state.ontology = None

    app = FastAPI(
        title="JARVIS embodied agent service",
        version=service_version(),
        description=DESCRIPTION,
        lifespan=lifespan,
        docs_url=None,  # FastAPI's pages load Swagger UI and ReDoc from a CDN; app.api_docs serves its own
        redoc_url=None,
    )
    app.state.settings = settings
    app.state.model_preload = None
    app.state.metrics = ServiceMetrics(
        lambda: None if getattr(app.state, "store", None) is None else len(app.state.store)
    )
    # 503 overloaded after request_queue_deadline_s, checked once a worker thread is free; the step route
    # checks in its own (single) worker thread, and health and metrics answer however busy the service is.
    stale = [Depends(refuse_stale_request)]
    app.include_router(health.router)
    app.include_router(metrics.router)
    app.include_router(sessions.router, dependencies=stale)
    app.include_router(steps.router)
    app.include_router(teach.router, dependencies=stale)
    install_api_docs(app)
    app.include_router(live.router)
    install_error_handlers(app)
    # The last middleware added runs first: log every request, including bodies refused for size.
    app.add_middleware(
        BodySizeLimit,
        max_body_bytes=settings.max_body_bytes,
        path_limits={START_EDH_PATH: (settings.max_edh_body_bytes, "JARVIS_MAX_EDH_BODY_BYTES")},
        read_timeout_s=settings.body_read_timeout_s,
    )
    app.add_middleware(KeyCheck, settings=settings)  # 401/429 before any body is read
    app.add_middleware(ConnectionRecycling, every=settings.requests_per_connection)
    app.add_middleware(RequestLog, metrics=app.state.metrics)  # request id, log event, HTTP metrics
    return app


def build_store(
    settings: Settings,
    ontology: Ontology,
    clock: Callable[[], float],
    on_snapshot: SnapshotObserver | None = None,
) -> tuple[SessionStore, RateLimiter]:
    """The session store and rate limiter the settings name: this process's, or Redis's (shared by every
    worker). ``clock`` drives the in-memory ones; Redis keeps time by its own clock. ``on_snapshot`` hears
    of every snapshot Redis's store writes or reads (the metrics)."""
    if not settings.uses_redis:
        store = InMemorySessionStore(settings.max_sessions, settings.session_ttl_s, clock=clock)
        return store, InMemoryRateLimiter(clock)
    redis_store = RedisSessionStore(
        settings.store,
        max_sessions=settings.max_sessions,
        ttl_s=settings.session_ttl_s,
        lease_s=settings.session_lease_s,
        ontology=ontology,
        prefix=settings.store_prefix,
        planners=lambda name: make_planner(name, ontology, planner_config(settings)),
        networks=network_paths(settings),
        on_snapshot=on_snapshot,
    )
    return redis_store, RedisRateLimiter(settings.store, prefix=settings.store_prefix)


def _log_access_mode(settings: Settings, keys: KeyRing) -> None:
    where = (
        "memory (this process)" if not settings.uses_redis else f"redis ({_without_password(settings.store)})"
    )
    if keys.open:
        _LOG.warning(
            "service_open",
            extra={
                "store": where,
                "detail": "no API keys configured (JARVIS_API_KEYS, JARVIS_API_KEYS_FILE): any client may "
                "read, step and delete any session, and no per-key quota applies",
            },
        )
    else:
        _LOG.info("service_keys", extra={"store": where, "keys": len(keys)})


def _without_password(url: str) -> str:
    """A store URL fit for a log line: the password, if any, replaced."""
    scheme, sep, rest = url.partition("://")
    credentials, at, host = rest.rpartition("@")
    if not at:
        return url
    user = credentials.split(":", 1)[0]
    return f"{scheme}{sep}{user}:***@{host}" if ":" in credentials else f"{scheme}{sep}***@{host}"


def limit_threads(threads: int) -> None:
    """The numeric libraries' thread pools in this worker process. Torch applies its setting to every
    thread started afterwards, which includes the worker threads requests run in; a torch not imported yet
    reads ``OMP_NUM_THREADS`` when it is (importing it here would cost an oracle-only service 1-2 s)."""
    cv2.setNumThreads(threads)
    if "torch" in sys.modules:
        sys.modules["torch"].set_num_threads(threads)
    else:
        os.environ["OMP_NUM_THREADS"] = str(threads)
