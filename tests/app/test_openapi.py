"""The OpenAPI document at /openapi.json (rendered at /docs) explains every field with an example."""

from __future__ import annotations

from fastapi.testclient import TestClient

from agent.explorers import EXPLORERS
from agent.navigation import NAVIGATORS
from agent.perception import PERCEPTION_BACKENDS
from agent.planning import PLANNERS


def test_every_schema_property_has_a_description_and_an_example(client: TestClient) -> None:
    schemas = client.get("/openapi.json").json()["components"]["schemas"]
    undocumented = [
        f"{name}.{prop}: missing {what}"
        for name, schema in schemas.items()
        for prop, spec in schema.get("properties", {}).items()
        for what, present in (
            ("description", bool(spec.get("description"))),
            ("example", "examples" in spec or "example" in spec),
        )
        if not present
    ]

    assert {"SessionCreate", "SessionPublic", "StepRequest", "StepResult", "ErrorBody", "TeachAction"} <= set(
        schemas
    )
    assert undocumented == []


def test_every_route_documents_its_errors_with_the_error_body(client: TestClient) -> None:
    paths = client.get("/openapi.json").json()["paths"]
    expected = {
        ("/v1/sessions", "post"),
        ("/v1/sessions", "get"),
        ("/v1/sessions/{session_id}", "get"),
        ("/v1/sessions/{session_id}", "delete"),
        ("/v1/sessions/{session_id}/utterances", "post"),
        ("/v1/sessions/{session_id}/step", "post"),
        ("/v1/sessions/{session_id}/trace", "get"),
        ("/v1/sessions/{session_id}/map.png", "get"),
        ("/healthz", "get"),
        ("/readyz", "get"),
        ("/metrics", "get"),
        ("/start_new_edh_instance", "post"),
        ("/get_next_action", "post"),
        ("/test", "get"),
        ("/ping", "get"),
    }
    never_fail = {("/healthz", "get"), ("/test", "get"), ("/ping", "get")}

    assert {(path, method) for path, item in paths.items() for method in item} == expected
    for path, method in expected - never_fail:
        responses = paths[path][method]["responses"]
        errors = [status for status in responses if status.startswith(("4", "5"))]
        assert errors, (path, method)
        for status in errors:
            ref = responses[status]["content"]["application/json"]["schema"]["$ref"]
            assert ref.endswith("/ErrorBody"), (path, method, status)


def test_docs_page_is_served(client: TestClient) -> None:
    response = client.get("/docs")

    assert response.status_code == 200
    assert "swagger" in response.text.lower()


def test_the_named_parts_a_session_picks_are_listed_as_their_registries_name_them(client: TestClient) -> None:
    create = client.get("/openapi.json").json()["components"]["schemas"]["SessionCreate"]["properties"]

    def allowed(field: str) -> list[str]:
        spec = create[field]
        options = [spec, *spec.get("anyOf", [])]
        return next(option["enum"] for option in options if "enum" in option)

    assert allowed("perception") == list(PERCEPTION_BACKENDS.names())
    assert allowed("navigator") == list(NAVIGATORS.names())
    assert allowed("planner") == list(PLANNERS.names())
    assert allowed("explorer") == list(EXPLORERS.names())


def test_an_unknown_perception_is_refused_naming_the_known_ones(client: TestClient) -> None:
    refused = client.post(
        "/v1/sessions", json={"mode": "tfd", "subgoals": "Open Fridge", "perception": "lidar"}
    )

    assert refused.status_code == 422 and refused.json()["error"] == "validation_error", refused.json()
    for name in PERCEPTION_BACKENDS.names():
        assert name in refused.json()["detail"], refused.json()
