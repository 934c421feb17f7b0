"""The executor's configuration: limits, budgets, distances and angles, each with its unit and reason."""

from __future__ import annotations

from dataclasses import dataclass, field

from agent.executor.clicks import ClickConfig
from agent.executor.looks import StainConfig
from agent.explorers import DEFAULT_EXPLORER, ExplorerName
from symbolic.predicates import DEFAULT_IGNORE_ATTEMPTS
from symbolic.thor import MAX_FAILED_ACTIONS, MAX_STEPS, TEACH_LOOK_STEP_DEG

__all__ = ["DEFAULT_EXPLORER", "STAND_CLEARANCE_M", "ExecutorConfig", "ExplorerName", "SearchConfig"]

STAND_CLEARANCE_M = 0.15
"""Metres the body's centre keeps from obstacles when standing and planning. AI2-THOR's reachable grid
(and our harness's) lets the 0.2 m capsule brush furniture edges: cells 0.15 m from a table or 0.125 m from
a wall are reachable. Planning with the full 0.2 m radius closes gaps and standing spots that exist (a plate
on a low table by the wall becomes unreachable); a move that does collide is remembered (Alg. 3 l. 66)."""


@dataclass(frozen=True)
class SearchConfig:
    """Budgets, distances and angles of the search for one subgoal's target, and of the container
    geometry it reads (fronts, doors, extents)."""

    # ----- budgets -----
    max_searches_per_step: int = 64  # search decisions in one step (each skipped container or surface
    # starts another): a bound on the loop
    better_explore_steps: int = 24  # actions of exploration, and ...
    better_containers: int = 4  # ... containers opened, looking for an instance that looks as the plan
    # needs (a clean mug) before one that looks wrong is taken (or when the search has nothing left)
    max_explore_steps: int = 80  # actions of frontier exploration per subgoal (a TEACh room is seen in
    # a few look-arounds; what is still missing then is more likely shut away than out of sight)
    max_surfaces: int = 12  # open receptacle parts walked to and looked at per subgoal
    max_containers: int = 12  # containers opened per subgoal (a TEACh kitchen has up to 30)
    max_hinted_containers: int = 36  # ... when the plan opened one of a type for the target: it is in one
    # of that type, so every cabinet of a kitchen may need opening
    inspect_viewpoints: int = 3  # other standing cells an open container is looked into from
    explore_horizon_deg: float = 30.0  # degrees down while exploring: floor near the body and counters
    # ahead are both in view with a 90° (TEACh) or 60° (ALFRED) vertical field of view

    # ----- container parts and candidates -----
    part_m: float = 0.5  # metres: a container cluster is visited in parts this wide (a cabinet door)
    min_part_cells: int = 6  # map cells a part needs to count (a sliver of a neighbour does not)
    upper_from_m: float = 1.45  # metres: bins from here up belong to wall cabinets, below to base ones
    band_gap_m: float = 0.4  # metres: parts further apart in height than this are different containers
    surface_part_m: float = 1.0  # metres: open receptacles are looked at in parts this wide
    checked_radius_m: float = 0.3  # metres: a container part this close to a checked one is that one
    part_penalty_m: float = 1.0  # metres added to a map part's distance when ordering the containers to
    # open: a part is a guess at a container (it may be a swung door's cells), a sighted instance is one
    sighted_part_m: float = 0.45  # metres (horizontally) within which a map part belongs to a sighted
    # instance of its type: it is that container, opened through the sighting
    sighted_band_m: float = 0.5  # metres (vertically) within which a map part and a sighted instance can be
    # one container (a wall cabinet is not the base cabinet under it)
    container_depth_m: float = 0.8  # metres a container reaches behind the face seen when clicking it
    # (AI2-THOR's fridges are 0.7-0.8 m deep): a closed fridge shows its door, the bread lies behind it
    same_door_m: float = 0.2  # metres: an opened instance seen this close to a container part's centre is
    # that part (farther, it is the neighbouring cabinet of the row, and this one still needs opening)
    near_row_m: float = 0.2  # metres beyond the nearest floor to a point that still count as its nearest
    # row (the 0.25 m lattice's nearest positions fit in a band this wide, the row behind them does not)

    # ----- where to stand to open and look in -----
    viewpoint_gap_m: float = 0.5  # metres between viewpoints on a container's front side
    low_face_m: float = 1.0  # metres: a container whose face is seen below this is a base cabinet or a
    # drawer, under a counter top
    stand_off_m: float = 0.75  # metres (horizontally) from a low container's face to where it is opened
    # and looked into from: the counter top hides its inside from a camera at 1.58 m standing closer (a
    # mug 0.38 m behind the face of a cabinet 0.85 m high shows from 0.78 m and not from 0.53 m)
    tall_stand_off_m: float = 0.4  # metres from a taller container's face (a fridge, a wall cabinet) to
    # where it is opened from: in front of it rather than beside it, where the swung door hides the shelves
    front_cone_deg: float = 35.0  # degrees either side of a container's facing within which it is opened
    # and looked into: from the side, its own walls and its swung door hide the inside
    tall_container_m: float = 1.2  # metres: an opened container seen this high or more is a tall one (a
    # fridge is 1.8 m, a cabinet under 0.9 m), whose inside its walls hide from beside it
    beside_deg: float = 60.0  # degrees off a container's front beyond which it was opened from beside it:
    # its walls hide the inside, which a search then looks into once more from in front

    # ----- fronts and doors (what opening a container shows) -----
    opened_part_m: float = 0.6  # metres around the click of an Open that belong to the container opened
    # (one fridge, one cabinet door)
    footprint_margin_m: float = 0.4  # metres beyond ``opened_part_m`` whose cells count toward an opened
    # container's footprint: its swung door adds cells up to a door's width in front
    container_reach_m: float = 1.0  # metres around a point of a container within which its mapped cells
    # are that container's body
    front_min_new_cells: int = 6  # map cells an opened door must add before its direction is trusted as
    # the container's front
    front_same_m: float = 0.5  # metres: a remembered front this close to a container (its cells, or the
    # centroid of a newer front) is that container's
    front_floor_share: float = 0.5  # share of the most open side's floor a remembered front needs to be
    # believed: a microwave's door swings sideways, so its swing can point at the wall beside it
    side_floor_m: tuple[float, float] = (0.4, 1.6)  # metres from a container's centre within which the
    # floor on each of its sides is counted (nearer is under its own door, farther is across the room)
    door_aside_m: float = 0.15  # metres across the front a swung door's cells must lie from the middle to
    # count as a side-hinged door (a drawer slides straight out)
    door_clearance_m: float = 0.1  # metres a viewpoint keeps inside the line of a swung door, so the door
    # does not hide what is inside

    # ----- container sightings (``sightings``: the instances of closed containers seen so far) -----
    sighting_same_id_m: float = 0.6  # metres, horizontally: a sighting with the same segmentation id this
    # close is the same instance (its centroid moves as more or less of it shows, up and down a 1.8 m
    # fridge most)
    sighting_same_place_m: float = 0.2  # metres: a sighting of the same type this close is the same
    # instance, whatever its id
    sighting_stride_px: int = 3  # pixels between the samples a frame's container instances are read from
    # (centroids, face normals)
    sighting_edge_m: float = 0.1  # metres: neighbouring samples farther apart than this straddle an edge
    # and cast no face vote
    sighting_upright: float = 0.5  # a normal whose vertical part is at most this fraction of its length
    # belongs to a vertical face
    sighting_min_pixels: int = 40  # visible pixels an instance needs to be remembered (a sliver at the
    # image edge places its point badly)


@dataclass(frozen=True)
class ExecutorConfig:
    """Limits and retry budgets of the executor (counts are per subgoal unless said otherwise)."""

    stand_clearance_m: float = STAND_CLEARANCE_M  # metres the body's centre keeps from obstacles
    look_step_deg: float = TEACH_LOOK_STEP_DEG  # degrees per Look Up/Down (TEACh 30, ALFRED 15)
    max_steps: int = MAX_STEPS  # actions per episode (TEACh)
    max_failed_actions: int = MAX_FAILED_ACTIONS  # failed actions per episode (TEACh)
    max_subgoals_per_step: int = 16  # Navigate subgoals can finish without an action; this bounds the chain
    # of them in one step
    retries_per_instance: int = 2  # failed clicks on one instance before another instance is tried
    failures_before_room: int = 2  # failed Places into one receptacle before an obstruction is taken out
    failures_per_stand: int = 2  # failed clicks from one standing spot before moving elsewhere
    max_failures: int = 6  # failed object actions before the subgoal is given up
    max_steps_per_subgoal: int = 300  # actions spent on one subgoal before it is given up
    max_given_up: int = 4  # subgoals given up before the episode stops
    retry_rounds: int = 1  # times the given-up subgoals are tried again when the plan runs out ...
    retry_min_steps: int = 100  # ... if at least this many actions of the episode are left (and a
    # subgoal's worth of failed actions, ``max_failures``)
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

    # ----- which instance -----
    bad_stand_radius_m: float = 0.3  # metres: goal cells this close to a given-up standing spot are skipped
    anchor_radius_m: float = 0.35  # metres: an instance this close to the remembered spot is that one
    part_radius_m: float = 0.4  # metres: the part of a row of same-type instances that is one of them
    done_radius_m: float = 0.3  # metres: an instance this close to a finished one is that one
    put_drift_m: float = 0.8  # metres: how far from the clicked spot a thing put down may come to rest (a
    # click on a basin's rim puts it in the free middle, up to a basin's width away)
    on_receptacle_m: float = 0.2  # metres from an object's point to a receptacle's nearest map cell for it
    # to lie on that receptacle (the object hides the top beneath it from the map)
    on_top_slack_m: float = 0.05  # metres an object's height may fall short of the lower edge of a
    # receptacle's top bin, still on it
    in_dish_m: float = 0.06  # the same as ``on_receptacle_m`` for a dish or pot: a potato beside a pot is
    # not in it
    stain_fragment_m: float = 0.2  # metres: with learned segmentation, a piece of a dish this near a
    # stained piece in the same view is the same dish (its rim, split off its stained middle)
    vanished_before_skipped: int = 2  # times a mapped X may vanish from the map as the agent walks to it
    # before it is passed over for the subgoal (a cup seen through an open door, hidden by the door nearer)

    # ----- getting there -----
    front_min_cells: int = 40  # standable cells (0.1 m² of 5 cm cells) a container's front side needs
    front_margin: float = 1.15  # the front side must have this many times the floor of the runner-up
    front_half_angle_deg: float = 30.0  # degrees either side of the front direction a viewpoint may lie
    sight_check_extent_m: float = 0.8  # metres: targets smaller than this get a line-of-sight check
    near_part_m: float = 1.5  # metres: of a longer cluster only the cells this much beyond its nearest
    # are walked to (the near end of a counter will do, and goal cells cost less to find)
    same_instance_m: float = 0.3  # metres: a mapped instance this close to a spot noted for one earlier in
    # the subgoal (walked toward last step, found unreachable, vanished) is that one
    vanished_near_m: float = 1.5  # metres: a mapped instance walked toward that is gone from the map this
    # near counts as vanished; farther off, small things drop in and out of the map from frame to frame
    blind_clicks: int = 2  # clicks a subgoal aims at a remembered spot where the target is not recognised
    where_put_lift_m: float = 0.03  # metres above the remembered spot (the receptacle's surface under X)
    # that such a click aims at
    where_put_hidden_m: float = 0.4  # metres: a pixel whose surface is this much nearer than the remembered
    # spot hides it (an X as tall as this, standing on the spot, is itself nearer than the spot)
    slot_above: float = 0.01  # share of the frame's height over a slot receptacle's top that a Pickup of
    # what stands in it aims at (a slice in a toaster shows 6-8 of 300 rows over it from 1.3-1.5 m)

    # ----- moving safely -----
    swing_clearance_m: float = 0.1  # metres: a held long object swings through the spot one move ahead;
    # the harness (like AI2-THOR's grid) lets the body centre come 0.15 m from furniture
    unstick_clearance_m: float = 0.12  # metres: room a move needs when the navigator sees no way out
    max_unstick: int = 3  # such moves per subgoal

    # ----- rows of switches (stove knobs) -----
    row_switch_steps: int = 16  # actions spent on the other switches of a row once one is done
    row_switch_gap_m: float = 0.08  # metres: a switch this close to one switched is that one (stove knobs
    # stand 0.12 m or more apart)
    row_reach_m: float = 1.2  # metres: the switches of one row lie within this of each other
    row_spacing_m: float = 0.3  # metres: the farthest apart two neighbouring switches of a row stand (the
    # generator's stove knobs stand 0.15-0.25 m apart)

    # ----- a commander's hints (TATC) -----
    hint_lookahead: int = 3  # hints that may be passed over to reach the one for this subgoal (repair may
    # have dropped a subgoal)
    at_pose_m: float = 0.1  # metres: standing this close to the hinted cell centre is standing on it
    hint_patience: int = 4  # steps the hinted cell may be out of the map's reach (a turn each, to see
    # more) before it is given up

    click: ClickConfig = field(default_factory=ClickConfig)
    search: SearchConfig = field(default_factory=SearchConfig)
    explorer: ExplorerName = DEFAULT_EXPLORER  # the explorer the search asks while X is not in the map
