"""The executor's one configuration object: limits, retry budgets, distances (units in the comments)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

from agent.executor.clicks import ClickConfig
from agent.executor.looks import StainConfig
from symbolic.predicates import DEFAULT_IGNORE_ATTEMPTS
from symbolic.thor import MAX_FAILED_ACTIONS, MAX_STEPS, TEACH_LOOK_STEP_DEG

STAND_CLEARANCE_M = 0.15
"""Metres the body's centre keeps from obstacles when standing and planning. AI2-THOR's reachable grid
(and our harness's) lets the 0.2 m capsule brush furniture edges: cells 0.15 m from a table or 0.125 m from
a wall are reachable. Planning with the full 0.2 m radius closes gaps and standing spots that exist (a plate
on a low table by the wall becomes unreachable); a move that does collide is remembered (Alg. 3 l. 66)."""


@dataclass(frozen=True)
class SearchConfig:
    """Budgets and radii of the search for one subgoal's target."""

    part_m: float = 0.5  # metres: a container cluster is visited in parts this wide (a cabinet door)
    min_part_cells: int = 6  # map cells a part needs to count (a sliver of a neighbour does not)
    upper_from_m: float = 1.45  # metres: bins from here up belong to wall cabinets, below to base ones
    band_gap_m: float = 0.4  # metres: parts further apart in height than this are different containers
    explore_horizon_deg: float = 30.0  # degrees down while exploring: floor near the body and counters
    # ahead are both in view with a 90° (TEACh) or 60° (ALFRED) vertical field of view
    better_explore_steps: int = 24  # actions of exploration, and ...
    better_containers: int = 4  # ... containers opened, looking for an instance that looks as the plan
    # needs (a clean mug) before one that looks wrong is taken (or when the search has nothing left)
    max_explore_steps: int = 80  # actions of frontier exploration per subgoal (a TEACh room is seen in
    # a few look-arounds; what is still missing then is more likely shut away than out of sight)
    surface_part_m: float = 1.0  # metres: open receptacles are looked at in parts this wide
    max_surfaces: int = 12  # open receptacle parts walked to and looked at per subgoal
    max_containers: int = 12  # containers opened per subgoal (a TEACh kitchen has up to 30)
    max_hinted_containers: int = 36  # ... when the plan opened one of a type for the target: it is in one
    # of that type, so every cabinet of a kitchen may need opening
    inspect_viewpoints: int = 3  # other standing cells an open container is looked into from
    viewpoint_gap_m: float = 0.5  # metres between viewpoints on a container's front side
    checked_radius_m: float = 0.3  # metres: a container part this close to a checked one is that one


ExplorerName = Literal["frontier", "goal_transformer"]
"""How the search explores while the target is not in the map: HLSM's frontier explorer, or the JARVIS
seed's goal transformer (``agent.exploration_gt``); ``bench/goal_transformer_vs_frontier.py``
compares them."""
EXPLORERS: tuple[ExplorerName, ...] = ("frontier", "goal_transformer")
DEFAULT_EXPLORER: ExplorerName = "frontier"
"""The explorer sessions get unless they ask: the better one in
``bench/results/goal_transformer_vs_frontier.json`` (task SR, then goal conditions, then search success)."""


@dataclass(frozen=True)
class ExecutorConfig:
    """Limits and retry budgets of the executor (counts are per subgoal unless said otherwise)."""

    stand_clearance_m: float = STAND_CLEARANCE_M  # metres the body's centre keeps from obstacles
    look_step_deg: float = TEACH_LOOK_STEP_DEG  # degrees per Look Up/Down (TEACh 30, ALFRED 15)
    max_steps: int = MAX_STEPS  # actions per episode (TEACh)
    max_failed_actions: int = MAX_FAILED_ACTIONS  # failed actions per episode (TEACh)
    retries_per_instance: int = 2  # failed clicks on one instance before another instance is tried
    failures_before_room: int = 2  # failed Places into one receptacle before an obstruction is taken out
    failures_per_stand: int = 2  # failed clicks from one standing spot before moving elsewhere
    max_failures: int = 6  # failed object actions before the subgoal is given up
    max_steps_per_subgoal: int = 300  # actions spent on one subgoal before it is given up
    max_given_up: int = 4  # subgoals given up before the episode stops
    retry_rounds: int = 1  # times the given-up subgoals are tried again when the plan runs out ...
    retry_min_steps: int = 100  # ... if at least this many actions of the episode are left (and a
    # subgoal's worth of failed actions, ``max_failures``)
    row_switch_steps: int = 16  # actions spent on the other switches of a row (stove knobs) once one is done
    look_sweep: int = 3  # camera pitches tried at a destination before moving around it
    stain: StainConfig = field(default_factory=StainConfig)
    ignore_after: int = DEFAULT_IGNORE_ATTEMPTS  # look-arounds at a mapped X, unseen, before Ignore(X)
    ignore_radius_m: float = 0.4  # metres around an ignored detection
    held_check_min_share: float = 0.004  # share of the frame a held object must cover before its look
    # is believed over the plan's (a knife at 0.45 m covers about 1%)
    false_detection_radius_m: float = 0.2  # metres around a spot learned segmentation misnamed (clicks
    # on it kept failing); small, as the real X may stand right beside it
    speck_max_pixels: int = 30  # with learned segmentation, an instance smaller than this (of a 300x300
    # frame) ...
    speck_share: float = 0.05  # ... and than this share of the largest of its type in view is a speck
    # bled onto a neighbour, not clicked (a sofa's bleed onto a credit card: 12 pixels beside 5,700)
    bad_stand_radius_m: float = 0.3  # metres: goal cells this close to a given-up standing spot are skipped
    anchor_radius_m: float = 0.35  # metres: an instance this close to the remembered spot is that one
    part_radius_m: float = 0.4  # metres: the part of a row of same-type instances that is one of them
    front_min_cells: int = 40  # standable cells (0.1 m² of 5 cm cells) a container's front side needs
    front_margin: float = 1.15  # the front side must have this many times the floor of the runner-up
    front_half_angle_deg: float = 30.0  # degrees either side of the front direction a viewpoint may lie
    sight_check_extent_m: float = 0.8  # metres: targets smaller than this get a line-of-sight check
    swing_clearance_m: float = 0.1  # metres: a held long object swings through the spot one move ahead;
    # the harness (like AI2-THOR's grid) lets the body centre come 0.15 m from furniture
    unstick_clearance_m: float = 0.12  # metres: room a move needs when the navigator sees no way out
    max_unstick: int = 3  # such moves per subgoal
    near_part_m: float = 1.5  # metres: of a longer cluster only the cells this much beyond its nearest
    # are walked to (the near end of a counter will do, and goal cells cost less to find)
    done_radius_m: float = 0.3  # metres: an instance this close to a finished one is that one
    put_drift_m: float = 0.8  # metres: how far from the clicked spot a thing put down may come to rest: a
    # click on a basin's rim puts it in the free middle, up to a basin's width away (0.56 m in game 0 of
    # the generated valid_unseen, where learned depth mapped the bowl 0.12 m further still)
    click: ClickConfig = field(default_factory=ClickConfig)
    search: SearchConfig = field(default_factory=SearchConfig)
    explorer: ExplorerName = DEFAULT_EXPLORER  # see ExplorerName
