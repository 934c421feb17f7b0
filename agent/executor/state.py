"""What the executor remembers between steps: JARVIS Algorithm 3's inputs beyond the map and the pointer.

Algorithm 3 carries the previous action (to judge it and to avoid repeating a failed one, line 80), the
belief the task-level rules reason over (updated by ``ExecutePostActionProcess`` on success, line 63) and,
for its false-detection rule, how often the agent looked around a mapped target without seeing it.
We add what a kitchen needs: where the agent last acted on each type (so "Close Fridge" closes the fridge
it opened and "Pickup Mug" takes the mug it washed), the progress on the current subgoal (failed clicks,
given-up standing positions, the search for an unmapped target) and the failure counts that bound an
episode. ``ExecutorState`` holds one part per concern, each written by the collaborator that owns it
(named in the part's docstring). Everything is plain data so the session snapshots compactly
(``agent.snapshot``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from agent.executor.clicks import Click
from agent.executor.looks import LookRecord
from agent.executor.mapview import IgnoredSpot
from agent.geometry import Pose
from agent.navigation.exploration import Explorer
from symbolic.belief import BeliefState
from symbolic.subgoals import Subgoal

Point = tuple[float, float, float]
"""World (x, y, z), metres."""
Spot = tuple[float, float]
"""World (x, z), metres."""
Box = tuple[Point, Point]
"""World (min corner, max corner), metres: a container's extent."""


def in_box(point: Point, box: Box, margin_m: float = 0.1) -> bool:
    """Whether a world point lies in a box grown by ``margin_m`` on every side."""
    lo, hi = box
    return all(lo[k] - margin_m <= point[k] <= hi[k] + margin_m for k in range(3))


PendingPurpose = Literal["plan", "search", "motion"]
"""What the previous action served: the plan's current subgoal, the container search, or getting somewhere."""


@dataclass
class Pending:
    """The action returned last step, kept to judge its outcome when the next frame arrives."""

    action: str
    purpose: PendingPurpose
    plan_index: int | None  # the subgoal it served
    pose: Pose  # where it was taken from
    click: Click | None = None
    colour: np.ndarray | None = None  # float32 [3]: the clicked instance's normalised colour before
    box: Box | None = None  # an Open's container: its extent as seen when clicking it (``opened_box``)
    before: tuple[float, float, int] | None = None  # an Open's container: mapped centroid x, z and cell
    # count near the click before the door swung (``Memory.fronts``)


@dataclass(frozen=True)
class Verdict:
    """The previous action, judged once when the next frame arrives (``Executor.judge``), before that frame
    enters the map: what it was, whether it worked, and what the hand holds now."""

    pending: Pending | None  # the action judged (None before the first step, after a Stop)
    success: bool | None  # None when there was no previous action to judge
    holding: bool  # the hand holds something in this frame (the map leaves the held object out)
    held_type: str | None  # what it holds, when known


FAILED_CLICK_RADIUS_M = 0.25
"""Metres: without persistent instance ids, an instance whose centre lies this close to a failed click's
world point is the instance that click failed on (a mug-sized object; a counter's clicks spread wider)."""


@dataclass(frozen=True)
class FailedClick:
    """A click whose action failed: on what, at which pixel, at which world point, from where."""

    instance_id: int
    row: int
    col: int
    point: Point
    stand: tuple[float, float, float, float]  # pose x, z, yaw, horizon it was made from

    @classmethod
    def of(cls, click: Click, pose: Pose) -> FailedClick:
        return cls(click.instance_id, click.row, click.col, click.point, stand_of(pose))

    def near(self, point: Point) -> bool:
        return sum((a - b) ** 2 for a, b in zip(self.point, point, strict=True)) <= FAILED_CLICK_RADIUS_M**2


def stand_of(pose: Pose) -> tuple[float, float, float, float]:
    """A pose rounded to what the grid and the look steps can tell apart (a failed click's viewpoint)."""
    return (round(pose.x, 2), round(pose.z, 2), round(pose.yaw) % 360, round(pose.horizon))


@dataclass(frozen=True)
class Hint:
    """A commander's help with one subgoal (TATC, ``symbolic.commands``): where to stand, in the map's
    frame, how far to look down there (degrees), and where to click from there (column, row fractions)."""

    subgoal: Subgoal
    stand: Pose | None = None
    look: float | None = None
    click: tuple[float, float] | None = None


@dataclass
class Memory:
    """Where the agent dealt with each object type (world points): later subgoals pick the same instance.
    Written as subgoals are carried out (``executor``), read by ``choice`` and ``approach``."""

    where: dict[str, Point] = field(default_factory=dict)
    """Type -> the last point the agent acted on it, or put it down."""
    done_ids: dict[str, list[int]] = field(default_factory=dict)
    """Type -> segmentation ids of the instances in ``done_with``: in view, the id decides."""
    done_with: dict[str, list[Spot]] = field(default_factory=dict)
    """Type -> spots of instances the plan has finished with; a new "Navigate X" means another X."""
    looks: dict[str, list[LookRecord]] = field(default_factory=dict)
    """Type -> (x, z, "clean" | "dirty", pixels read) of instances the stain cue judged (``looks``)."""
    source: dict[str, Point] = field(default_factory=dict)
    """Type -> where instances of it came from (the pieces of a slice): more may lie hidden there."""
    instance: dict[str, int] = field(default_factory=dict)
    """Type -> segmentation id of the instance the agent last picked up (AI2-THOR's ids, and ours, are
    stable within an episode): after putting it down, the plan's next use of the type means that one."""
    fronts: list[tuple[float, float, float, float]] = field(default_factory=list)
    """(x, z, direction in degrees, door) of containers whose front showed when they opened: the door swings
    out in front, so the new cells lie that way (a fridge in a corner faces the narrow gap, not the room);
    ``door`` (metres, signed) is how far across the front from (x, z) the new cells lie: the hinge side."""
    opened_box: dict[str, Box] = field(default_factory=dict)
    """Container type -> world box of the one last opened: "Open Cabinet, Pickup Plate" means the plate in
    there, not a dirty one in the sink beside it."""
    switched_on: dict[str, list[tuple[int, Point]]] = field(default_factory=dict)
    """Switch type -> (segmentation id, where) of the switches of a row (stove knobs) the agent turned on."""
    hint_pose: Pose | None = None
    """Where the agent stands after reaching a commander's stand hint: the clicks hinted next hold there."""
    pins: list[tuple[str, str, int]] = field(default_factory=list)
    """(action, type, segmentation id): the next subgoal "action type" means that instance (``room``)."""
    room_made_in: list[str] = field(default_factory=list)
    """Receptacle types the agent took an obstruction out of (``room``): at most once each."""
    placed_into: dict[str, list[str]] = field(default_factory=dict)
    """Type -> receptacle types the instance of it the agent handles was put into since it first took it
    up: a plan that takes an X up to put it where this one already went means another X."""
    stored_in: dict[str, tuple[Point, int | None]] = field(default_factory=dict)
    """Closed container type (cabinet, drawer) -> (where, segmentation id) of the one the plan last put
    something into: the plan's next "Place Cabinet" means that one ("put all the cups in one cabinet"),
    not the nearest, which may be the one the next cup was just taken out of."""


@dataclass
class Sighting:
    """One container instance seen (``sightings``): where its visible face's centroid is, from the fullest
    view so far."""

    object_type: str
    point: Point
    instance_id: int
    pixels: int  # pixels of the view the point came from
    searched_for: list[str] = field(default_factory=list)  # target types it was opened (or tried) for
    faces: list[int] = field(default_factory=lambda: [0, 0, 0, 0])  # samples of its vertical faces seen
    # looking toward 0°, 90°, 180° and -90° (``sightings.observe``)


@dataclass
class SearchMemory:
    """What the container search learned in the episode, by target type (``search``, ``visit``)."""

    looked_into: dict[str, list[Box]] = field(default_factory=dict)  # containers looked into
    opened_for: dict[str, list[int]] = field(default_factory=dict)  # container ids opened
    looked_at: dict[str, list[Box]] = field(default_factory=dict)  # open receptacles looked at from near
    containers: list[Sighting] = field(default_factory=list)  # container instances seen (``sightings``)


@dataclass
class Detections:
    """Table 5's Ignore (``detections``): spots ruled out for a type, and how often the agent looked around a
    mapped X without seeing it. The step's map view reads both."""

    ignored: list[IgnoredSpot] = field(default_factory=list)
    explore_attempts: dict[str, int] = field(default_factory=dict)  # type -> destination look-arounds


@dataclass
class MotionMemory:
    """What moving taught (``motion``): Alg. 3 line 80's failed motion, and turns a held object blocks."""

    last_failed_action: str | None = None  # the previous action, when it failed (Alg. 3 line 80)
    blocked_turns: list[tuple[float, float, float, str]] = field(default_factory=list)
    """(x, z, yaw, turn) of turns that failed: holding something long, the way it would swing is blocked."""
    long_held: list[str] = field(default_factory=list)  # held types a turn failed with (too long to swing)
    manoeuvre: list[str] = field(default_factory=list)  # motions left of a side step made to turn with it


@dataclass
class Progress:
    """How the episode's plan went so far (``executor``): the counts TEACh's limits bound, and what a
    re-plan or a retry starts from."""

    failed_actions: int = 0  # every action judged failed (TEACh's failure limit counts them all)
    given_up: int = 0  # subgoals abandoned to repair
    missing: list[str] = field(default_factory=list)  # planned types searched for in vain (``standin``)
    retry: list[Subgoal] = field(default_factory=list)  # given-up subgoals, with what repair dropped along,
    # for one more round when the plan runs out (``PlanProgress.retry_given_up``)
    retry_rounds: int = 0  # such rounds begun
    completed: list[Subgoal] = field(default_factory=list)  # subgoals carried out, in order (a re-plan's
    # history)


@dataclass
class ContainerVisit:
    """One closed container opened to look for the target (the search's last resort)."""

    object_type: str
    target: Point  # the container part to open: its mapped cells' centre, at the middle of its height band
    top_low_m: float  # metres: the lowest its top can be (reach to it is judged on this)
    stage: Literal["look", "open", "inspect", "close"] = "open"  # "look": an open receptacle, looked at
    near: bool = False  # a "look" from the row of floor nearest to it at the explore pitch, or none
    opened_at: Point | None = None
    instance_id: int | None = None  # the instance opened (segmentation ids are stable within an episode)
    inspect_steps: int = 0  # horizons looked into it from the current viewpoint
    sweep: list[float] = field(default_factory=list)  # horizons still to look into it from here
    viewpoints: int = 0  # other standing cells it was looked into from
    seen_from: list[Spot] = field(default_factory=list)  # standing cells it was looked into from
    moving: bool = False  # walking to another viewpoint
    side: float | None = None  # direction (degrees) of the side being walked to
    sides: list[float] = field(default_factory=list)  # sides of it walked to so far
    hinted: bool = False  # the plan opened it for the target (so it is worth a second viewpoint)
    reopen: bool = False  # its own open door bars the way to its front: close it, open it from there
    reopened: bool = False  # it was closed and opened again from in front (once per visit)
    extent: Box | None = None  # the opened instance's extent as seen when opening it
    looks: int = 0  # turns and pitch changes spent without a clickable view of it


@dataclass
class SearchState:
    """How far the search for an unmapped target has got (``search``, ``visit``)."""

    explorer: Explorer | None = None
    explore_steps: int = 0
    exhausted: bool = False  # frontier exploration has nothing left to show
    visit: ContainerVisit | None = None
    containers_opened: int = 0
    prefer: str | None = None  # container type the plan hints at (it just opened one for the target)
    surfaces_looked: int = 0  # open receptacle parts looked at
    hinted: bool = False  # the hint was looked for
    switch_looked: bool = False  # the close look beside what a switch controls was considered
    doors_closed: int = 0  # containers the search closed (each may free a way its open door barred)
    unseen_opens: list[int] = field(default_factory=list)  # instances whose Open changed nothing in view


@dataclass
class RowProgress:
    """The switches of a row (stove knobs) switched for the current subgoal (``switches``)."""

    switched: list[tuple[int, Point]] = field(default_factory=list)  # (id, where) of those switched
    steps: int = 0  # actions spent on the rest of the row since the first switch
    pan: str | None = None  # a sideways step to see the rest of the row past the view's edge (once)
    panned: bool = False  # that step was taken
    late_switch: Click | None = None  # a switch of the row seen only while turning it off: to turn on now
    late_switched: list[Point] = field(default_factory=list)  # where such late switches were clicked


@dataclass
class Attempt:
    """Progress on the plan's current subgoal; replaced when the pointer moves."""

    index: int
    subgoal: Subgoal
    first_step: int
    steps: int = 0
    failures: int = 0  # failed object actions for this subgoal
    failed_clicks: list[FailedClick] = field(default_factory=list)
    bad_stands: list[Spot] = field(default_factory=list)  # standing spots where it kept failing
    unreachable: list[tuple[Spot, int]] = field(default_factory=list)  # mapped clusters the navigator could
    # not reach, with ``search.doors_closed`` at the time (``InstanceChoice.found_unreachable``)
    heading_for: Spot | None = None  # the mapped instance walked toward last step (x, z)
    vanished: list[Spot] = field(default_factory=list)  # where one walked toward was gone from the map
    glanced: list[Spot] = field(default_factory=list)  # standing cells it pitched toward a seen X from
    destination_looks: int = 0  # looks at the destination without seeing the target, this visit
    look_sweep: list[float] = field(default_factory=list)  # horizons still to try at the destination
    any_instance: bool = False  # the remembered instance was not found where it was put: take any
    unsticks: int = 0  # moves made because the navigator saw no way out
    tried_source: bool = False  # went to look where the type's pieces came from
    search: SearchState = field(default_factory=SearchState)
    hint: Hint | None = None  # the commander's help with this subgoal (TATC)
    hint_failed: bool = False  # the hinted stand could not be reached: the agent's own way then
    hint_misses: int = 0  # steps the navigator found no way to the hinted stand
    pinned: int | None = None  # the one instance this subgoal means (``Memory.pins``)
    full: list[Box] = field(default_factory=list)  # extents of receptacles a Place kept failing on: full
    hint_checked: bool = False  # the container the plan opened for the target was looked into
    accept_second: bool = False  # a look around found nothing better than a second-rate instance
    row: RowProgress = field(default_factory=RowProgress)
    blind_clicks: int = 0  # clicks aimed at a remembered spot of the target (``Approach.click_remembered``)

    def instance_failures(self, instance_id: int, point: Point, persistent_ids: bool) -> int:
        """Failed clicks on an instance: by its id when ids persist across frames (the oracle's), else the
        ones made at its world ``point`` (``FAILED_CLICK_RADIUS_M``)."""
        if persistent_ids:
            return sum(1 for failed in self.failed_clicks if failed.instance_id == instance_id)
        return sum(1 for failed in self.failed_clicks if failed.near(point))

    def avoided_pixels(
        self, instance_id: int, pose: Pose, persistent_ids: bool
    ) -> tuple[tuple[int, int], ...]:
        """Pixels of earlier failed clicks a retry should not hit again: those on the instance (persistent
        ids), or those made from this very viewpoint (ids renumbered each frame)."""
        if persistent_ids:
            return tuple((f.row, f.col) for f in self.failed_clicks if f.instance_id == instance_id)
        here = stand_of(pose)
        return tuple((f.row, f.col) for f in self.failed_clicks if f.stand == here)


@dataclass
class ExecutorState:
    """Everything the executor carries from one step to the next, one part per concern."""

    belief: BeliefState
    memory: Memory = field(default_factory=Memory)
    searched: SearchMemory = field(default_factory=SearchMemory)
    detections: Detections = field(default_factory=Detections)
    motion: MotionMemory = field(default_factory=MotionMemory)
    progress: Progress = field(default_factory=Progress)
    hints: list[Hint] = field(default_factory=list)  # the commander's, in plan order, not yet used
    attempt: Attempt | None = None
    pending: Pending | None = None
