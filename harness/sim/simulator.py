"""The step function: TEACh's 17 driver actions on a World, each success or failure with its reason.

Semantics follow AI2-THOR as TEACh drives it (``SimulatorTHOR.add_interaction``): the body moves one
0.25 m grid cell or turns 90°, the camera tilts in 30° steps (15° for ALFRED); an object action takes a
click point, resolves it through the instance mask (``harness.sim.clicks``), refuses targets whose clicked
surface lies outside AI2-THOR's 1.5 m reach cylinder about the agent's vertical axis (``harness.sim.reach``),
applies its effect and then the contact rules of
``harness.sim.physics``. ALFRED's action names map onto the same semantics. Failures carry the categories of
the JARVIS seed's Table 8 (``harness.sim.failures``).

Our simplifications, stated so nobody mistakes them for AI2-THOR's physics:
- Collide when rotating: AI2-THOR sweeps the held object's collider through the turn. We fail a turn when
  the held object is longer than HELD_COLLISION_SIZE_M in any dimension and the grid cell the agent
  would then face is not free.
- The held object's world position rides at the renderer's HAND_OFFSET_M in front of the camera (AI2-THOR
  reports the hand's position for it too); its contents ride along.
- Reach is measured at the surface point seen at the resolved object's pixel nearest the click (TEACh
  raycasts at the click itself; a click just beside a near object would then be judged by the wall
  behind it), where AI2-THOR accepts an object when any of its visibility points is in reach.
- Not modelled: Table 8's "collide when picking up / placing" (objects never clip here) and Break.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from harness.render.camera import CameraPose, CameraSpec, camera_to_world, pixel_ray_tables
from harness.render.geometry import HAND_OFFSET_M
from harness.render.renderer import Frame, Renderer
from harness.sim import physics
from harness.sim.clicks import ClickHit, click_pixel, click_radius_px, resolve_click
from harness.sim.failures import FailureReason
from harness.sim.navgrid import blocks_movement, cell_is_reachable, reachable_grid
from harness.sim.reach import horizontal_distance
from harness.world.model import World, WorldObject
from symbolic.ontology import ObjectTypeInfo, Ontology, load_ontology
from symbolic.thor import (
    GRID_STEP_M,
    HORIZON_MAX_DEG,
    HORIZON_MIN_DEG,
    INTERACTION_DISTANCE_M,
    OBJECT_ACTIONS,
    TEACH_DRIVER_ACTIONS,
    TEACH_LOOK_STEP_DEG,
    TURN_STEP_DEG,
)

ALFRED_ACTIONS: dict[str, str] = {
    "MoveAhead": "Forward",
    "MoveBack": "Backward",
    "MoveLeft": "Pan Left",
    "MoveRight": "Pan Right",
    "RotateLeft": "Turn Left",
    "RotateRight": "Turn Right",
    "LookUp": "Look Up",
    "LookDown": "Look Down",
    "PickupObject": "Pickup",
    "PutObject": "Place",
    "OpenObject": "Open",
    "CloseObject": "Close",
    "ToggleObjectOn": "ToggleOn",
    "ToggleObjectOff": "ToggleOff",
    "SliceObject": "Slice",
    "<<stop>>": "Stop",
}
"""AI2-THOR/ALFRED action names and the TEACh action with the same semantics."""

MOVE_HEADINGS_DEG: dict[str, int] = {"Forward": 0, "Pan Right": 90, "Backward": 180, "Pan Left": 270}
"""Direction of each body move relative to the agent's yaw (Pan is AI2-THOR's MoveLeft/MoveRight strafe)."""

TURNS_DEG: dict[str, int] = {"Turn Left": -TURN_STEP_DEG, "Turn Right": TURN_STEP_DEG}
"""Yaw change per turn; Turn Right adds 90 as AI2-THOR's RotateRight does."""

LOOK_SIGN: dict[str, int] = {"Look Up": -1, "Look Down": 1}
"""Horizon change direction; positive horizon looks down in AI2-THOR."""

HELD_COLLISION_SIZE_M = 0.3
"""A held object longer than this in any dimension can hit things when the agent turns."""

MUST_BE_OFF_TO_OPEN = frozenset({"Microwave"})
"""AI2-THOR: "Target must be OFF to open!" (the seed's "cannot open when running")."""

MUST_BE_CLOSED_TO_TURN_ON = frozenset({"Microwave"})
"""AI2-THOR's CanToggleOnOff.MustBeClosedToTurnOn."""

Affordance = Callable[[ObjectTypeInfo, Ontology], bool]

AFFORDANCES: dict[str, Affordance] = {
    "Pickup": lambda info, _: info.pickupable,
    "Place": lambda info, _: info.receptacle,
    "Open": lambda info, _: info.openable,
    "Close": lambda info, _: info.openable,
    "ToggleOn": lambda info, _: info.toggleable,
    "ToggleOff": lambda info, _: info.toggleable,
    "Slice": lambda info, _: info.sliceable,
    "Pour": lambda info, ontology: info.fillable or info.name in ontology.pour_basins,
}
"""What a click target must be for each object action (TEACh's action_to_affordances, minus the state
conditions: a redundant Open fails as ALREADY_IN_STATE instead of finding nothing). Pouring into one of the
ontology's ``pour_basins`` just empties the held container."""

LACKING: dict[str, FailureReason] = {
    "Pickup": FailureReason.NOT_PICKUPABLE,
    "Place": FailureReason.RECEPTACLE_INCOMPATIBLE,
    "Open": FailureReason.NOT_OPENABLE,
    "Close": FailureReason.NOT_OPENABLE,
    "ToggleOn": FailureReason.NOT_TOGGLEABLE,
    "ToggleOff": FailureReason.NOT_TOGGLEABLE,
    "Slice": FailureReason.NOT_SLICEABLE,
    "Pour": FailureReason.POUR_NOT_POSSIBLE,
}
"""The failure when the clicked object exists but lacks the affordance."""

Point = tuple[float, float, float]


@dataclass(frozen=True)
class ActionResult:
    """What happened: the TEACh action name, success, why not, a readable message, the object acted on."""

    action: str
    success: bool
    failure: FailureReason | None
    message: str
    object_id: str | None = None


def canonical_action(name: str) -> str | None:
    """The TEACh driver action a TEACh or ALFRED name means, or None for an unknown name."""
    if name in TEACH_DRIVER_ACTIONS:
        return name
    return ALFRED_ACTIONS.get(name)


def _ok(action: str, message: str, object_id: str | None = None) -> ActionResult:
    return ActionResult(action, True, None, message, object_id)


def _fail(action: str, reason: FailureReason, message: str, object_id: str | None = None) -> ActionResult:
    return ActionResult(action, False, reason, message, object_id)


class Simulator:
    """One episode's simulator; ``world`` is mutated in place by ``step``.

    Contact rules are applied once on construction, as TEACh checks its custom properties when an episode
    starts (a dirty mug already under a running faucet is clean from the first frame).
    """

    def __init__(
        self,
        world: World,
        camera: CameraSpec,
        *,
        look_step_deg: int = TEACH_LOOK_STEP_DEG,
        renderer: Renderer | None = None,
    ) -> None:
        if renderer is not None and renderer.spec != camera:
            raise ValueError(f"renderer draws {renderer.spec}, but the camera is {camera}")
        self.world = world
        self.camera = camera
        self.look_step_deg = look_step_deg
        self.renderer = renderer if renderer is not None else Renderer(camera)
        self.ontology = load_ontology()
        self.history: list[ActionResult] = []
        self._click_radius = click_radius_px(camera.width, camera.height)
        self._x_over_z, self._y_over_z = pixel_ray_tables(camera)  # [W], [H]
        self._grid_key: tuple[object, ...] | None = None
        self._grid = np.zeros((0, 0), dtype=bool)
        self._frames_key: tuple[object, ...] | None = None
        self._frames: dict[tuple[str, int | None], Frame] = {}
        self._effects: dict[str, Callable[[WorldObject, Point], ActionResult]] = {
            "Pickup": self._pickup,
            "Place": self._place,
            "Open": self._open,
            "Close": self._close,
            "ToggleOn": self._toggle_on,
            "ToggleOff": self._toggle_off,
            "Slice": self._slice,
            "Pour": self._pour,
        }
        physics.apply_rules(world, self.ontology)
        self._carry_held()

    # ---- observation -------------------------------------------------------------------------------

    def observe(self, noise_seed: int | None = None) -> Frame:
        """The egocentric frame for the current state; rendered once per state and noise seed."""
        frames = self._current_frames()
        key = ("rgb", noise_seed)
        if key not in frames:
            frames[key] = self.renderer.render(self.world, noise_seed=noise_seed)
        return frames[key]

    def _geometry_frame(self) -> Frame:
        """Any frame of the current state: depth and instances do not depend on the noise seed."""
        frames = self._current_frames()
        if not frames:
            frames[("geometry", None)] = self.renderer.render(self.world, want_rgb=False)
        return next(iter(frames.values()))

    def _current_frames(self) -> dict[tuple[str, int | None], Frame]:
        key = self._state_key()
        if key != self._frames_key:
            self._frames_key, self._frames = key, {}
        return self._frames

    def _state_key(self) -> tuple[object, ...]:
        """Every mutable field of the agent and the objects; equal keys render identical frames."""
        return (
            tuple(vars(self.world.agent).values()),
            tuple(tuple(vars(o).values()) for o in self.world.objects.values()),
        )

    # ---- stepping ----------------------------------------------------------------------------------

    def step(self, action: str, x: float | None = None, y: float | None = None) -> ActionResult:
        """Execute one action; ``x``, ``y`` are the click's column and row as fractions of the frame."""
        name = canonical_action(action)
        if name is None:
            known = ", ".join([*TEACH_DRIVER_ACTIONS, *ALFRED_ACTIONS])
            result = _fail(action, FailureReason.INVALID_ACTION, f"unknown action {action!r}; known: {known}")
        elif name == "Stop":
            result = _ok(name, "stopped")
        elif name in MOVE_HEADINGS_DEG:
            result = self._move(name)
        elif name in TURNS_DEG:
            result = self._turn(name)
        elif name in LOOK_SIGN:
            result = self._look(name)
        else:
            result = self._interact(name, x, y)
        self.history.append(result)
        return result

    # ---- motion ------------------------------------------------------------------------------------

    def reachable(self) -> np.ndarray:
        """bool [NX, NZ] reachable cells; recomputed only when something that blocks walking moved."""
        held = self.world.agent.held
        key = tuple(
            (o.object_id, o.center, o.size) for o in self.world.objects.values() if blocks_movement(o, held)
        )
        if key != self._grid_key:
            self._grid_key, self._grid = key, reachable_grid(self.world)
        return self._grid

    def _cell_ahead(self, heading_deg: int) -> tuple[float, float]:
        """Centre of the neighbouring cell in a heading (yaw 0 = +z, 90 = +x)."""
        agent = self.world.agent
        rad = math.radians(heading_deg)
        x = agent.x + GRID_STEP_M * round(math.sin(rad))
        z = agent.z + GRID_STEP_M * round(math.cos(rad))
        return self.world.room.cell_center(*self.world.room.cell_of(x, z))

    def _move(self, name: str) -> ActionResult:
        agent = self.world.agent
        x, z = self._cell_ahead(agent.yaw + MOVE_HEADINGS_DEG[name])
        if not cell_is_reachable(self.world, self.reachable(), x, z):
            return _fail(name, FailureReason.BLOCKED, f"something blocks the way to ({x:.2f}, {z:.2f})")
        agent.x, agent.z = x, z
        self._carry_held()
        return _ok(name, f"moved to ({x:.2f}, {z:.2f})")

    def _turn(self, name: str) -> ActionResult:
        agent = self.world.agent
        yaw = (agent.yaw + TURNS_DEG[name]) % 360
        held = self.world.held_object()
        if held is not None and max(held.size) > HELD_COLLISION_SIZE_M:
            x, z = self._cell_ahead(yaw)
            if not cell_is_reachable(self.world, self.reachable(), x, z):
                return _fail(
                    name,
                    FailureReason.COLLIDE_ROTATING,
                    f"the held {held.object_type} would hit something turning to yaw {yaw}",
                    held.object_id,
                )
        agent.yaw = yaw
        self._carry_held()
        return _ok(name, f"turned to yaw {yaw}")

    def _look(self, name: str) -> ActionResult:
        agent = self.world.agent
        horizon = agent.horizon + LOOK_SIGN[name] * self.look_step_deg
        if not HORIZON_MIN_DEG - 1e-6 <= horizon <= HORIZON_MAX_DEG + 1e-6:
            return _fail(
                name,
                FailureReason.LOOK_LIMIT,
                f"horizon {horizon:g}° is outside [{HORIZON_MIN_DEG}, {HORIZON_MAX_DEG}]",
            )
        agent.horizon = horizon
        self._carry_held()
        return _ok(name, f"horizon {horizon:g}°")

    def _camera_pose(self) -> CameraPose:
        return CameraPose.of_agent(self.world.agent)

    def _carry_held(self) -> None:
        """Keep the held object (and what rests on it) in the hand, in front of the camera."""
        held = self.world.held_object()
        if held is None:
            return
        pose = self._camera_pose()
        hand = pose.position + camera_to_world(pose) @ np.array(HAND_OFFSET_M)
        physics.move_with_contents(self.world, held, (float(hand[0]), float(hand[1]), float(hand[2])))

    # ---- object interaction ------------------------------------------------------------------------

    def resolve_click(self, x: float, y: float, affordance: str) -> str | None:
        """The object id an object action named ``affordance`` (e.g. "Pickup", "PutObject") would act on
        at click (x, y), or None; distance is not checked here."""
        name = canonical_action(affordance)
        if name not in AFFORDANCES:
            raise ValueError(f"unknown object action {affordance!r}; known: {', '.join(OBJECT_ACTIONS)}")
        found = self._resolve(self._geometry_frame(), x, y, name)
        return found[0].object_id if found else None

    def _resolve(self, frame: Frame, x: float, y: float, name: str) -> tuple[WorldObject, ClickHit] | None:
        affordance = AFFORDANCES[name]

        def wanted(instance_id: int) -> bool:
            obj = self._target_of(frame, instance_id)
            return obj is not None and affordance(self.ontology.get(obj.object_type), self.ontology)

        hit = resolve_click(frame.instances, x, y, wanted, self._click_radius)
        if hit is None:
            return None
        target = self._target_of(frame, hit.instance_id)
        assert target is not None, f"instance {hit.instance_id} passed the filter but has no object"
        return target, hit

    def _target_of(self, frame: Frame, instance_id: int) -> WorldObject | None:
        """The interactable object drawn with this instance id: not structure, not in the agent's hand."""
        object_id = frame.object_ids.get(instance_id)
        obj = self.world.objects.get(object_id) if object_id is not None else None
        if obj is None or self.ontology.get(obj.object_type).structural:
            return None
        held = self.world.agent.held
        if held is not None and (object_id == held or held in self.world.parent_chain(obj.object_id)):
            return None
        return obj

    def _interact(self, name: str, x: float | None, y: float | None) -> ActionResult:
        if x is None or y is None or not (0.0 <= x <= 1.0 and 0.0 <= y <= 1.0):
            return _fail(
                name, FailureReason.INVALID_ACTION, f"{name} needs a click (x, y) in [0, 1], got ({x}, {y})"
            )
        refused = self._precondition(name)
        if refused is not None:
            return refused
        frame = self._geometry_frame()
        found = self._resolve(frame, x, y, name)
        if found is None:
            row, col = click_pixel(x, y, self.camera.width, self.camera.height)
            there = self._target_of(frame, int(frame.instances[row, col]))
            if there is None:
                return _fail(name, FailureReason.NOTHING_AT_POINT, f"nothing to {name} at ({x:.3f}, {y:.3f})")
            return _fail(name, LACKING[name], f"cannot {name} {there.object_type}", there.object_id)
        target, hit = found
        point = self._surface_point(frame, hit.row, hit.col)
        agent = self.world.agent
        distance = float(horizontal_distance(np.array(point), agent.x, agent.z))
        if distance > INTERACTION_DISTANCE_M:
            return _fail(
                name,
                FailureReason.TOO_FAR,
                f"{target.object_id} is {distance:.2f} m from the agent (limit {INTERACTION_DISTANCE_M} m)",
                target.object_id,
            )
        result = self._effects[name](target, point)
        if result.success:
            physics.apply_rules(self.world, self.ontology)
        return result

    def _precondition(self, name: str) -> ActionResult | None:
        """Checks TEACh makes on the hand before it looks at the click."""
        held = self.world.held_object()
        if name == "Place" and held is None:
            return _fail(name, FailureReason.NOTHING_HELD, "not holding anything to place")
        if name == "Slice" and (held is None or held.object_type not in self.ontology.slicing_tools):
            tools = " or ".join(self.ontology.slicing_tools)
            return _fail(name, FailureReason.KNIFE_NOT_IN_HAND, f"slicing needs a {tools} in hand")
        if name == "Pour" and (held is None or not held.is_filled):
            what = "nothing" if held is None else f"an empty {held.object_type}"
            return _fail(name, FailureReason.POUR_NOT_POSSIBLE, f"holding {what}; nothing to pour")
        return None

    def _surface_point(self, frame: Frame, row: int, col: int) -> Point:
        """The world point of the surface seen at a pixel."""
        depth = float(frame.depth[row, col])
        ray_cam = np.array([self._x_over_z[col], self._y_over_z[row], 1.0])  # camera frame, z = 1
        pose = self._camera_pose()
        point = pose.position + depth * (camera_to_world(pose) @ ray_cam)
        return (float(point[0]), float(point[1]), float(point[2]))

    # ---- effects (the target is resolved, visible and within reach) --------------------------------

    def _pickup(self, target: WorldObject, point: Point) -> ActionResult:
        agent = self.world.agent
        if agent.held is not None:
            return _fail(
                "Pickup", FailureReason.HAND_OCCUPIED, f"already holding {agent.held}", target.object_id
            )
        for receptacle_id in self.world.parent_chain(target.object_id):
            receptacle = self.world.objects[receptacle_id]
            if physics.encloses(receptacle.object_type, self.ontology) and not receptacle.is_open:
                return _fail(
                    "Pickup",
                    FailureReason.INSIDE_CLOSED,
                    f"inside the closed {receptacle_id}",
                    target.object_id,
                )
        target.parent_id = None
        target.picked_up = True
        agent.held = target.object_id
        self._carry_held()
        return _ok("Pickup", f"Picked up {target.object_type}", target.object_id)

    def _place(self, receptacle: WorldObject, point: Point) -> ActionResult:
        held = self.world.held_object()
        assert held is not None, "Place precondition guarantees a held object"
        if not self.ontology.accepts(receptacle.object_type, held.object_type):
            return _fail(
                "Place",
                FailureReason.RECEPTACLE_INCOMPATIBLE,
                f"{held.object_type} cannot be placed in/on {receptacle.object_type}",
                receptacle.object_id,
            )
        if physics.encloses(receptacle.object_type, self.ontology) and not receptacle.is_open:
            return _fail(
                "Place",
                FailureReason.RECEPTACLE_CLOSED,
                f"{receptacle.object_id} is closed",
                receptacle.object_id,
            )
        carries_something = bool(self.world.children(held.object_id))
        spot = physics.resting_center(
            self.world, held, receptacle, near=point, may_turn=not carries_something
        )
        if spot is None:
            return _fail(
                "Place",
                FailureReason.RECEPTACLE_FULL,
                f"no room for {held.object_type} in/on {receptacle.object_id}",
                receptacle.object_id,
            )
        center, size = spot
        held.size = size
        physics.move_with_contents(self.world, held, center)
        held.parent_id = receptacle.object_id
        self.world.agent.held = None
        return _ok("Place", f"Placed in {receptacle.object_id}", receptacle.object_id)

    def _open(self, target: WorldObject, point: Point) -> ActionResult:
        oid = target.object_id
        if target.is_open:
            return _fail("Open", FailureReason.ALREADY_IN_STATE, f"{oid} is already open", oid)
        if target.object_type in MUST_BE_OFF_TO_OPEN and target.is_toggled:
            return _fail("Open", FailureReason.CANNOT_OPEN_WHEN_RUNNING, f"{oid} must be off", oid)
        target.is_open = True
        return _ok("Open", f"Opened {target.object_type}", oid)

    def _close(self, target: WorldObject, point: Point) -> ActionResult:
        oid = target.object_id
        if not target.is_open:
            return _fail("Close", FailureReason.ALREADY_IN_STATE, f"{oid} is already closed", oid)
        target.is_open = False
        return _ok("Close", f"Closed {target.object_type}", oid)

    def _toggle_on(self, target: WorldObject, point: Point) -> ActionResult:
        oid = target.object_id
        if target.is_toggled:
            return _fail("ToggleOn", FailureReason.ALREADY_IN_STATE, f"{oid} is already on", oid)
        if target.object_type in MUST_BE_CLOSED_TO_TURN_ON and target.is_open:
            return _fail(
                "ToggleOn",
                FailureReason.MUST_BE_CLOSED_TO_TURN_ON,
                f"{oid} must be closed",
                oid,
            )
        physics.set_toggled(self.world, target, True)
        return _ok("ToggleOn", f"Turned on {target.object_type}", oid)

    def _toggle_off(self, target: WorldObject, point: Point) -> ActionResult:
        oid = target.object_id
        if not target.is_toggled:
            return _fail("ToggleOff", FailureReason.ALREADY_IN_STATE, f"{oid} is already off", oid)
        physics.set_toggled(self.world, target, False)
        return _ok("ToggleOff", f"Turned off {target.object_type}", oid)

    def _slice(self, target: WorldObject, point: Point) -> ActionResult:
        oid = target.object_id
        if target.is_sliced:
            return _fail("Slice", FailureReason.ALREADY_IN_STATE, f"{oid} is already sliced", oid)
        pieces = physics.slice_object(self.world, target, self.ontology)
        return _ok("Slice", f"Sliced {target.object_type} into {len(pieces)} pieces", oid)

    def _pour(self, target: WorldObject, point: Point) -> ActionResult:
        held = self.world.held_object()
        assert held is not None and held.liquid is not None, (
            "Pour precondition guarantees a filled held object"
        )
        liquid = held.liquid
        if target.object_type not in self.ontology.pour_basins:
            if target.is_filled:
                return _fail(
                    "Pour",
                    FailureReason.ALREADY_IN_STATE,
                    f"{target.object_id} already holds {target.liquid}",
                    target.object_id,
                )
            target.liquid = liquid
        held.liquid = None
        return _ok("Pour", f"Poured {liquid} into {target.object_type}", target.object_id)
