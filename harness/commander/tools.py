"""TEACh's commander tools over the harness world: ProgressCheck, SearchObject, SelectOid.

TEACh gives its commander oracle access to the simulator through these three calls (the TEACh paper's
TATC setting; the JARVIS seed, §"Two-Agent Task Completion"): ProgressCheck lists the task's goal
conditions still unmet (its ``problem_keys``: object, property, wanted value), SearchObject locates the
instances of an object type, SelectOid locates one instance by id. A location here is the object's
position, what it sits in or on, a pose the follower can stand at to act on it, and — with the
ground-truth segmentation — where it shows in the follower's frame from that pose.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from harness.expert.expert import ExpertConfig, goal_report
from harness.expert.navigation import (
    THOROUGH_SIGHT_RENDERS,
    BodyState,
    SightOracle,
    View,
    choose_clicks,
    find_view,
    posed,
    reduced_spec,
    search_motion,
)
from harness.expert.recipes import Task
from harness.render.camera import CameraPose, CameraSpec
from harness.render.renderer import Renderer
from harness.sim.navgrid import reachable_grid
from harness.sim.simulator import Simulator
from harness.tasks.progress import GoalReport
from harness.world.catalog import load_catalog
from harness.world.model import World
from symbolic.commands import CLICK_DECIMALS
from symbolic.ontology import Ontology, load_ontology
from symbolic.thor import INTERACTION_DISTANCE_M, TEACH_LOOK_STEP_DEG

CHECK_SIDE_PX = 300  # visibility renders at the follower's resolution divided down to this
MAX_VIEW_RENDERS = 40  # poses tried per SearchObject answer before saying "no pose found"
REACH_MARGIN_M = 0.01  # clicks stay this far inside the reach, as the expert's do
POSE_ATTEMPTS = 3  # views tried per budget when the action must work from the view (the expert's number)


@dataclass(frozen=True)
class ObjectLocation:
    """SearchObject's and SelectOid's answer for one instance."""

    object_id: str
    object_type: str
    position: tuple[float, float, float]
    parents: tuple[str, ...]
    """Types of what it is in or on, innermost first (``("Cabinet",)``)."""
    stand: tuple[float, float, float] | None
    """(x, z, yaw): a reachable pose from which it can be acted on; None if none was found."""
    horizon: float | None
    click: tuple[float, float] | None
    """(column, row) fractions where it shows from ``stand`` at ``horizon`` (ground-truth segmentation)."""


class CommanderTools:
    """The three calls, for one world and the follower's camera."""

    def __init__(
        self, camera: CameraSpec, look_step_deg: int = TEACH_LOOK_STEP_DEG, ontology: Ontology | None = None
    ) -> None:
        self.camera = camera
        self.look_step_deg = look_step_deg
        self.ontology = ontology or load_ontology()
        self.renderer = Renderer(reduced_spec(camera, CHECK_SIDE_PX))
        expert = ExpertConfig()
        self.sight = SightOracle(
            self.renderer, camera, look_step_deg, expert.reach_margin_m, expert.max_sight_renders
        )
        """The expert planner's look-ahead: which objects can be acted on from some reachable pose."""

    def progress_check(self, task: Task, world: World) -> GoalReport:
        """ProgressCheck: the task's goal conditions now, with those still unmet."""
        return goal_report(task, world, self.ontology)

    def search_object(self, world: World, object_type: str) -> list[ObjectLocation]:
        """SearchObject: every instance of the type, those the follower can act on first, nearest first."""
        found = [o.object_id for o in world.objects.values() if o.object_type == object_type]
        located = [self.select_oid(world, object_id) for object_id in found]
        agent = world.agent
        return sorted(
            located,
            key=lambda loc: (
                loc.stand is None,
                (loc.position[0] - agent.x) ** 2 + (loc.position[2] - agent.z) ** 2,
            ),
        )

    def select_oid(self, world: World, object_id: str, action: str | None = None) -> ObjectLocation:
        """SelectOid: one instance's location (KeyError for an id the world does not hold). With ``action``
        (a TEACh action name), the standing pose and click are ones from which that action on the object
        works in the simulator (tried on a copy of the world), as the expert's are."""
        target = world.objects[object_id]
        parents = tuple(world.objects[p].object_type for p in world.parent_chain(object_id))
        stand = horizon = click = None
        if world.agent.held != object_id:
            view = self._view(world, object_id, action)
            if view is not None:
                x, z = world.room.cell_center(view.state.ix, view.state.iz)
                stand, horizon = (x, z, float(view.state.yaw)), float(view.horizon)
                click = view.clicks[0]
        return ObjectLocation(
            object_id=object_id,
            object_type=target.object_type,
            position=(float(target.center[0]), float(target.center[1]), float(target.center[2])),
            parents=parents,
            stand=stand,
            horizon=horizon,
            click=click,
        )

    def click_from_here(self, world: World, object_id: str, action: str) -> tuple[float, float] | None:
        """Where to click for ``action`` on the object from the follower's pose now, as (column, row)
        fractions of its frame: a pixel of it within reach (the ground-truth segmentation) at which the
        simulator resolves the action to it (not to something lying on it); None when there is none."""
        frame = self.renderer.render(world, want_rgb=False)
        clicks = choose_clicks(
            frame,
            self.renderer.spec,
            CameraPose.of_agent(world.agent),
            world.instance_ids[object_id],
            self.camera,
            INTERACTION_DISTANCE_M - REACH_MARGIN_M,
        )
        simulator = Simulator(world, self.camera, look_step_deg=self.look_step_deg)
        return next((c for c in clicks if simulator.resolve_click(*_shown(c), action) == object_id), None)

    def _view(self, world: World, object_id: str, action: str | None) -> View | None:
        """The cheapest view within the quick budget, else within the thorough one (the expert's search);
        with ``action``, the first of up to POSE_ATTEMPTS views per budget from which it works."""
        agent = world.agent
        grid = reachable_grid(world)
        ix, iz = world.room.cell_of(agent.x, agent.z)
        reach = search_motion(grid, BodyState(ix, iz, agent.yaw))
        top_y = self._top_y(world, object_id) if action == "Place" else None
        tried: set[tuple[BodyState, float]] = set()
        for budget in (MAX_VIEW_RENDERS, THOROUGH_SIGHT_RENDERS):
            for _ in range(POSE_ATTEMPTS):
                view = find_view(
                    world,
                    object_id,
                    reach,
                    self.renderer,
                    self.camera,
                    self.look_step_deg,
                    top_y=top_y,
                    reach_margin_m=REACH_MARGIN_M,
                    max_renders=budget,
                    exclude=frozenset(tried),
                    ignore_motion=True,
                )
                if view is None:
                    break
                if action is None:
                    return view
                working = self._working_click(world, view, action)
                if working is not None:
                    return replace(view, clicks=(working,))
                tried.add((view.state, view.horizon))
        return None

    def _working_click(self, world: World, view: View, action: str) -> tuple[float, float] | None:
        """The view's first click (as the instruction will show it) at which ``action`` succeeds from its
        pose, tried on a copy of the world; None when none does."""
        for click in view.clicks:
            trial = posed(world.copy(), view.state, view.horizon)
            simulator = Simulator(trial, self.camera, look_step_deg=self.look_step_deg)
            if simulator.step(action, *_shown(click)).success:
                return _shown(click)
        return None

    @staticmethod
    def _top_y(world: World, receptacle_id: str) -> float | None:
        """Placing on a top surface: its height, so the click lands on its free part (the expert's rule)."""
        catalog = load_catalog()
        kind = world.objects[receptacle_id].object_type
        if catalog.placement(kind) != "on" or catalog.single_slot(kind):
            return None
        return world.objects[receptacle_id].top


def _shown(click: tuple[float, float]) -> tuple[float, float]:
    """The click as the instruction's text carries it (``symbolic.commands``: three decimals)."""
    return round(click[0], CLICK_DECIMALS), round(click[1], CLICK_DECIMALS)
