"""The service acts: oracle subgoals in a generated kitchen, driven frame by frame through the step route,
each returned action executed in the real simulator, until the agent says it is done."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from executor_support import drive, kitchen
from fastapi.testclient import TestClient

from app.main import create_app
from app.settings import Settings


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    with TestClient(create_app(Settings(log_level="warning"))) as test_client:
        yield test_client


def test_pick_and_place_moves_the_apple_onto_a_counter(client: TestClient) -> None:
    world = kitchen()
    (apple,) = world.of_type("Apple")
    before = (apple.parent_id, apple.center)

    run = drive(client, world, "Navigate Apple, Pickup Apple, Navigate CounterTop, Place CounterTop")

    moved = run.sim.world.objects[apple.object_id]
    assert run.last["done"] and run.last["action"] == "Stop", run.last
    assert run.last["plan"]["pointer"] == len(run.last["plan"]["subgoals"])
    assert run.sim.world.agent.held is None
    assert moved.parent_id is not None and moved.parent_id.startswith("CounterTop"), moved.parent_id
    assert (moved.parent_id, moved.center) != before
    assert run.failed() <= 2, [r.message for r in run.results if not r.success]


def test_slice_plan_fetches_the_knife_and_slices_the_bread(client: TestClient) -> None:
    world = kitchen()
    (bread,) = world.of_type("Bread")

    run = drive(client, world, "Slice Bread")  # repair inserts Navigate Knife, Pickup Knife, Navigate Bread

    texts = [subgoal["text"] for subgoal in run.answers[0]["plan"]["subgoals"]]
    assert texts == ["Navigate Knife", "Pickup Knife", "Navigate Bread", "Slice Bread"]
    assert run.last["done"], run.last
    assert bread.object_id not in run.sim.world.objects  # AI2-THOR replaces a sliced object by its pieces
    assert run.sim.world.of_type("BreadSliced")
    held = run.sim.world.held_object()
    assert held is not None and held.object_type == "Knife"


def test_without_poses_the_agent_dead_reckons_and_still_succeeds(client: TestClient) -> None:
    world = kitchen()
    (apple,) = world.of_type("Apple")

    run = drive(client, world, "Navigate Apple, Pickup Apple", give_pose=False)

    assert run.last["done"], run.last
    assert run.sim.world.agent.held == apple.object_id


def test_every_answer_names_the_rule_behind_it(client: TestClient) -> None:
    run = drive(client, kitchen(), "Navigate Bread, Pickup Bread")

    reasons = [answer["reason"] for answer in run.answers]
    assert all(reasons)
    assert any(r.startswith(("Target(Bread)", "FindInMap(Bread)", "search(Bread)")) for r in reasons), reasons
    assert any(r.startswith("Interactive(Pickup, Bread)") for r in reasons), reasons
    pickup = next(a for a in run.answers if a["action"] == "Pickup")
    assert 0.0 <= pickup["x"] <= 1.0 and 0.0 <= pickup["y"] <= 1.0
    assert pickup["subgoal"] == "Pickup Bread"
