"""``GET /metrics``: the service's Prometheus metrics (``app.metrics``), as Prometheus text."""

from __future__ import annotations

from fastapi import APIRouter, Response

from app.api.responses import error_responses
from app.metrics import MetricsDep

router = APIRouter(tags=["health"])


@router.get(
    "/metrics",
    response_class=Response,
    responses={
        200: {"content": {"text/plain": {}}, "description": "Prometheus text exposition format."},
        **error_responses(401, 429),  # with API keys configured, a scraper sends one too
    },
    summary="Prometheus metrics: requests, errors, step stages, planner calls, snapshots, live sessions",
)
async def metrics(registry: MetricsDep) -> Response:
    # async: a scrape renders a few hundred lines, cheaper than a worker-thread hop.
    body, content_type = registry.render()
    return Response(content=body, media_type=content_type)
