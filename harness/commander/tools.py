"""TEACh's commander tools over the harness world: ProgressCheck, SearchObject, SelectOid.

TEACh gives its commander oracle access to the simulator through these three calls (the TEACh paper's
TATC setting; the JARVIS seed, §"Two-Agent Task Completion"): ProgressCheck lists the task's goal
conditions still unmet (its ``problem_keys``: object, property, wanted value), SearchObject locates the
instances of an object type, SelectOid locates one instance by id. A location here is the object's
position, what it sits in or on, a pose the follower can stand at to act on it, and — with the
ground-truth segmentation — where it shows in the follower's frame from that pose.
"""

from __future__ import annotations

from dataclasses import dataclass

from harness.camera import CameraSpec
from harness.expert.expert import goal_report
from harness.expert.navigation import BodyState, View, find_view, reduced_spec, search_motion
from harness.expert.recipes import Task
from harness.navgrid import reachable_grid
from harness.render import Renderer
from harness.tasks.progress import GoalReport
from harness.world import World
from symbolic.ontology import Ontology, load_ontology
from symbolic.thor import TEACH_LOOK_STEP_DEG

CHECK_SIDE_PX = 300  # visibility renders at the follower's resolution divided down to this
MAX_VIEW_RENDERS = 40  # poses tried per SearchObject answer before saying "no pose found"


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

    def select_oid(self, world: World, object_id: str) -> ObjectLocation:
        """SelectOid: one instance's location (KeyError for an id the world does not hold)."""
        target = world.objects[object_id]
        parents = tuple(world.objects[p].object_type for p in world.parent_chain(object_id))
        stand = horizon = click = None
        if world.agent.held != object_id:
            view = self._view(world, object_id)
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

    def _view(self, world: World, object_id: str) -> View | None:
        agent = world.agent
        grid = reachable_grid(world)
        ix, iz = world.room.cell_of(agent.x, agent.z)
        reach = search_motion(grid, BodyState(ix, iz, agent.yaw))
        return find_view(
            world,
            object_id,
            reach,
            self.renderer,
            self.camera,
            self.look_step_deg,
            max_renders=MAX_VIEW_RENDERS,
            ignore_motion=True,
        )
