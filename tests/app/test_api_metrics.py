"""``GET /metrics``: Prometheus text an unmodified scraper parses, with the numbers an operator alerts on."""

from __future__ import annotations

from collections.abc import Callable

import pytest
from app_support import SMALL_CAMERA, oracle_observation
from fastapi.testclient import TestClient
from prometheus_client.parser import text_string_to_metric_families
from prometheus_client.samples import Sample

from app.metrics import STEP_STAGES, ServiceMetrics

STEP_ROUTE = "/v1/sessions/{session_id}/step"


def _scrape(client: TestClient) -> dict[str, list[Sample]]:
    response = client.get("/metrics")
    assert response.status_code == 200
    assert response.headers["content-type"].startswith("text/plain; version=")
    return {family.name: family.samples for family in text_string_to_metric_families(response.text)}


def _value(samples: list[Sample], name: str, **labels: str) -> float:
    matching = [
        s.value for s in samples if s.name == name and all(s.labels.get(k) == v for k, v in labels.items())
    ]
    assert len(matching) == 1, f"{name}{labels}: {len(matching)} samples in {samples}"
    return float(matching[0])


def test_a_session_and_a_step_show_in_the_metrics(client: TestClient) -> None:
    created = client.post(
        "/v1/sessions", json={"mode": "tfd", "subgoals": "Slice Bread", "camera": SMALL_CAMERA}
    )
    session_id = created.json()["session_id"]
    assert client.post(f"/v1/sessions/{session_id}/step", json=oracle_observation()).status_code == 200
    assert client.get("/v1/sessions/no-such-session").status_code == 404

    metrics = _scrape(client)

    requests = metrics["jarvis_http_requests"]
    assert _value(requests, "jarvis_http_requests_total", route=STEP_ROUTE, method="POST", status="200") == 1
    assert (
        _value(requests, "jarvis_http_requests_total", route="/v1/sessions", method="POST", status="201") == 1
    )
    assert not any(session_id in s.labels.get("route", "") for s in requests)  # templates, never ids
    latency = metrics["jarvis_http_request_duration_seconds"]
    assert _value(latency, "jarvis_http_request_duration_seconds_count", route=STEP_ROUTE, status="200") == 1
    assert _value(metrics["jarvis_steps"], "jarvis_steps_total") == 1
    stages = metrics["jarvis_step_stage_duration_seconds"]
    for stage in STEP_STAGES:
        assert _value(stages, "jarvis_step_stage_duration_seconds_count", stage=stage) == 1
        assert _value(stages, "jarvis_step_stage_duration_seconds_bucket", stage=stage, le="+Inf") == 1
    assert _value(stages, "jarvis_step_stage_duration_seconds_sum", stage="total") > 0
    assert _value(metrics["jarvis_sessions_live"], "jarvis_sessions_live") == 1
    assert _value(metrics["jarvis_http_errors"], "jarvis_http_errors_total", code="session_not_found") == 1


@pytest.mark.parametrize(
    ("request_", "code"),
    [
        (lambda c: c.get("/no/such/route"), "not_found"),
        (
            lambda c: c.post("/v1/sessions", content=b"{", headers={"content-type": "application/json"}),
            "malformed_json",
        ),
        (lambda c: c.post("/v1/sessions", content=b"x" * (65 * 1024)), "payload_too_large"),
    ],
    ids=["unknown-route", "malformed-json", "body-limit-413"],
)
def test_every_error_body_is_counted_by_its_code(
    client: TestClient, request_: Callable[[TestClient], object], code: str
) -> None:
    request_(client)

    errors = _scrape(client)["jarvis_http_errors"]

    assert _value(errors, "jarvis_http_errors_total", code=code) == 1


def test_a_body_refused_before_routing_is_labelled_with_its_route_template(client: TestClient) -> None:
    client.post("/v1/sessions/abc/step", content=b"x" * (65 * 1024))
    client.get("/no/such/route")

    requests = _scrape(client)["jarvis_http_requests"]

    assert _value(requests, "jarvis_http_requests_total", route=STEP_ROUTE, status="413") == 1
    assert _value(requests, "jarvis_http_requests_total", route="unmatched", status="404") == 1


def test_each_app_counts_only_its_own_requests(make_client: Callable[..., TestClient]) -> None:
    first, second = make_client(), make_client()
    first.get("/healthz")
    first.get("/healthz")
    second.get("/healthz")

    def health_count(client: TestClient) -> float:
        requests = _scrape(client)["jarvis_http_requests"]
        return _value(requests, "jarvis_http_requests_total", route="/healthz", method="GET", status="200")

    assert (health_count(first), health_count(second)) == (2, 1)


def test_snapshot_and_planner_timings_reach_their_histograms() -> None:
    metrics = ServiceMetrics(lambda: None)
    metrics.observe_snapshot("save", 0.004, 150_000)
    metrics.observe_snapshot("load", 0.002, 150_000)
    metrics.observe_planner_call(0.09)

    families = {f.name: f.samples for f in text_string_to_metric_families(metrics.render()[0].decode())}

    assert (
        _value(families["jarvis_snapshot_bytes"], "jarvis_snapshot_bytes_bucket", op="save", le="250000.0")
        == 1
    )
    assert (
        _value(families["jarvis_snapshot_bytes"], "jarvis_snapshot_bytes_bucket", op="save", le="100000.0")
        == 0
    )
    assert (
        _value(
            families["jarvis_snapshot_duration_seconds"], "jarvis_snapshot_duration_seconds_count", op="load"
        )
        == 1
    )
    assert (
        _value(families["jarvis_planner_call_duration_seconds"], "jarvis_planner_call_duration_seconds_sum")
        == 0.09
    )
    assert "jarvis_sessions_live" not in families  # no store yet: no sample rather than a made-up zero
    with pytest.raises(ValueError, match="'save' or 'load'"):
        metrics.observe_snapshot("delete", 0.0, 0)  # type: ignore[arg-type]


def test_a_language_planner_call_made_while_serving_is_timed(client: TestClient) -> None:
    dialogue = [{"speaker": "Commander", "text": "make a cup of coffee"}]
    assert client.post("/v1/sessions", json={"mode": "tfd", "dialogue": dialogue}).status_code == 201

    planner = _scrape(client)["jarvis_planner_call_duration_seconds"]

    assert _value(planner, "jarvis_planner_call_duration_seconds_count") == 1
    assert _value(planner, "jarvis_planner_call_duration_seconds_sum") > 0
