"""Driving the real agent with the real harness: a generated kitchen rendered by the Simulator, each frame
sent to the service (over FastAPI's TestClient) or to an AgentSession, each returned action executed."""

from __future__ import annotations

import base64
import math
from dataclasses import dataclass, field, fields
from typing import Any

from fastapi.testclient import TestClient

from agent.geometry import Camera, Pose
from agent.perception import Observation
from agent.planning import make_planner
from agent.session import AgentSession, SessionSpec, StepDecision
from harness.drive.client import FrameEncoding, observation_parts, pose_of
from harness.render.camera import CameraSpec
from harness.render.renderer import Frame
from harness.sim.physics import resting_center
from harness.sim.simulator import ActionResult, Simulator
from harness.world.model import AgentState, World, WorldObject
from harness.world.procedural.generate import generate_kitchen
from symbolic.ontology import load_ontology
from symbolic.thor import OBJECT_ACTIONS

CAMERA = {"width": 300, "height": 300, "hfov_deg": 90.0}
SPEC_FIELDS = frozenset(spec_field.name for spec_field in fields(SessionSpec))
"""300x300 frames keep an episode to seconds; TEACh's own are 900x900."""
KITCHEN_ITEMS = (("Apple", 1), ("Bread", 1), ("Knife", 1))
ENCLOSING = frozenset({"Cabinet", "Drawer", "Fridge", "Microwave", "Safe", "Box"})


def _in_the_open(world: World) -> bool:
    things = [o for name, _ in KITCHEN_ITEMS for o in world.of_type(name)]
    return len(things) == len(KITCHEN_ITEMS) and not any(
        world.objects[p].object_type in ENCLOSING for o in things for p in world.parent_chain(o.object_id)
    )


KITCHEN_SEED = next(s for s in range(100) if _in_the_open(generate_kitchen(s, require=KITCHEN_ITEMS)))
"""The first generated kitchen whose only Apple, Bread and Knife lie in the open (no closed container): the
tests that use it are about acting, not searching; found, not fixed, so the generator may change."""


def kitchen() -> World:
    return generate_kitchen(KITCHEN_SEED, require=KITCHEN_ITEMS)


def simulator(world: World) -> Simulator:
    return Simulator(world, CameraSpec(CAMERA["width"], CAMERA["height"], CAMERA["hfov_deg"]))


def step_body(frame: Frame, agent: AgentState | None, step: int | None) -> dict[str, Any]:
    """A JSON StepRequest for a frame, encoded as the harness client encodes it."""
    parts = observation_parts(frame, FrameEncoding())
    body: dict[str, Any] = {name: base64.b64encode(data).decode() for name, data in parts.items()}
    body["segmentation_legend"] = {str(k): v for k, v in frame.legend.items()}
    if agent is not None:
        body["pose"] = pose_of(agent)
    if step is not None:
        body["step"] = step
    return body


def observation(frame: Frame, agent: AgentState | None) -> Observation:
    """The decoded observation the service would build from ``step_body`` (no PNG round trip)."""
    pose = None
    if agent is not None:
        pose = Pose(agent.x, agent.z, float(agent.yaw % 360), float(agent.horizon))
    return Observation(
        rgb=frame.rgb, depth=frame.depth, instances=frame.instances, legend=dict(frame.legend), pose=pose
    )


def execute(sim: Simulator, action: str, x: float | None, y: float | None) -> ActionResult:
    return sim.step(action, x, y) if action in OBJECT_ACTIONS else sim.step(action)


def oracle_session(subgoals: str, **options: Any) -> AgentSession:
    """A TfD session (unless ``options`` say otherwise) with oracle perception, the FMM navigator and the
    oracle planner on ``subgoals``, seeing ``CAMERA``'s frames."""
    ontology = load_ontology()
    camera = Camera(CAMERA["width"], CAMERA["height"], CAMERA["hfov_deg"])
    chosen = {name: options.pop(name) for name in SPEC_FIELDS & options.keys()}
    spec = SessionSpec(
        **{"mode": "tfd", "camera": camera, "perception": "oracle", "navigator": "fmm", **chosen}
    )
    planner = make_planner("oracle", ontology)
    return AgentSession.start("s", spec, planner, given_subgoals=subgoals, ontology=ontology, **options)


def step_through(session: AgentSession, sim: Simulator, steps: int) -> list[StepDecision]:
    """The session's decisions on up to ``steps`` frames of the simulator (frame k with noise seed k), each
    action executed, until one says the episode is done."""
    decisions = []
    for step in range(steps):
        decisions.append(session.step_once(observation(sim.observe(noise_seed=step), sim.world.agent)))
        if decisions[-1].done:
            break
        execute(sim, decisions[-1].action, decisions[-1].x, decisions[-1].y)
    return decisions


@dataclass
class Drive:
    """One driven episode: the session, every answer and what the simulator made of each action."""

    session_id: str
    sim: Simulator
    answers: list[dict[str, Any]] = field(default_factory=list)
    results: list[ActionResult] = field(default_factory=list)

    @property
    def last(self) -> dict[str, Any]:
        return self.answers[-1]

    def failed(self) -> int:
        return sum(1 for r in self.results if not r.success)


def drive(
    client: TestClient,
    world: World,
    subgoals: str | None,
    *,
    max_steps: int = 400,
    give_pose: bool = True,
    session: dict[str, Any] | None = None,
) -> Drive:
    """Create a session (TfD with oracle ``subgoals``, or the ``session`` body given) and run it until
    the agent says done (or max_steps)."""
    body = session or {"mode": "tfd", "subgoals": subgoals}
    created = client.post("/v1/sessions", json={"camera": CAMERA, "seed": 0, **body})
    assert created.status_code == 201, created.text
    run = Drive(session_id=created.json()["session_id"], sim=simulator(world))
    for step in range(max_steps):
        frame = run.sim.observe(noise_seed=step)
        agent = run.sim.world.agent if give_pose else None
        response = client.post(f"/v1/sessions/{run.session_id}/step", json=step_body(frame, agent, step))
        assert response.status_code == 200, response.text
        answer = response.json()
        run.answers.append(answer)
        if answer["done"]:
            break
        run.results.append(execute(run.sim, answer["action"], answer["x"], answer["y"]))
    return run


def put(world: World, thing: WorldObject, holder: WorldObject) -> None:
    """Rest ``thing`` in or on ``holder`` where there is room (the test fails if there is none)."""
    spot = resting_center(world, thing, holder)
    assert spot is not None, f"no room for {thing.object_id} in/on {holder.object_id}"
    thing.center, thing.size = spot
    thing.parent_id = holder.object_id


def boiling_pot_on_a_burner_whose_knob_is_not_the_nearest() -> tuple[World, WorldObject]:
    """Kitchen 0 with a pot of water holding a potato on a burner switched by a knob that is not the one
    nearest to it (which knob heats which burner is not written on the stove, in AI2-THOR either)."""
    world = generate_kitchen(0, require=(("Potato", 1), ("Pot", 1)))
    knobs = world.of_type("StoveKnob")
    burner = next(
        b
        for b in world.of_type("StoveBurner")
        if min(knobs, key=lambda k: math.dist(k.center, b.center)).controls != b.object_id
    )
    pot, potato = world.of_type("Pot")[0], world.of_type("Potato")[0]
    put(world, pot, burner)
    put(world, potato, pot)
    pot.liquid = "water"
    return world, potato
