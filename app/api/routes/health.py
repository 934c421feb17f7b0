"""Liveness and readiness probes for an orchestrator (Kubernetes-style ``/healthz`` and ``/readyz``).

Liveness answers as soon as the process serves; readiness waits for the models the lifespan preloads
(``app.preload``), so traffic is routed to a replica only once a session can be served without a load.
"""

from __future__ import annotations

import redis
from fastapi import APIRouter, Request

from app.api.responses import error_responses
from app.errors import NOT_READY, ApiError
from app.preload import ModelPreload
from app.schemas import HealthOut, ReadyOut
from app.version import service_version

router = APIRouter(tags=["health"])


@router.get("/healthz", response_model=HealthOut, summary="Liveness: the process answers")
def healthz() -> HealthOut:
    return HealthOut(status="ok", version=service_version())


@router.get(
    "/readyz",
    response_model=ReadyOut,
    responses=error_responses(503),
    summary="Readiness: the session store, the ontology and the models sessions need are loaded",
)
def readyz(request: Request) -> ReadyOut:
    store = getattr(request.app.state, "store", None)
    ontology = getattr(request.app.state, "ontology", None)
    missing = [name for name, part in (("session store", store), ("ontology", ontology)) if part is None]
    preload: ModelPreload | None = getattr(request.app.state, "model_preload", None)
    if preload is not None:
        missing += preload.pending()  # the language planner, the perception networks (app.preload)
    if store is None or ontology is None or missing:
        raise ApiError(503, NOT_READY, f"not loaded yet: {', '.join(missing)}")
    try:
        store.check()
    except redis.RedisError as error:
        raise ApiError(
            503, NOT_READY, f"the session store does not answer ({type(error).__name__})"
        ) from error
    return ReadyOut(status="ready", sessions=len(store), object_types=len(ontology.types))
