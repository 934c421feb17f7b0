"""Liveness and readiness probes for an orchestrator (Kubernetes-style ``/healthz`` and ``/readyz``)."""

from __future__ import annotations

from fastapi import APIRouter, Request

from app.api.responses import error_responses
from app.errors import NOT_READY, ApiError
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
    summary="Readiness: the session store and the ontology are loaded",
)
def readyz(request: Request) -> ReadyOut:
    store = getattr(request.app.state, "store", None)
    ontology = getattr(request.app.state, "ontology", None)
    missing = [name for name, part in (("session store", store), ("ontology", ontology)) if part is None]
    if store is None or ontology is None:
        raise ApiError(503, NOT_READY, f"not loaded yet: {', '.join(missing)}")
    return ReadyOut(status="ready", sessions=len(store), object_types=len(ontology.types))
