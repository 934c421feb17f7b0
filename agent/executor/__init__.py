"""The action-level executor (JARVIS Algorithm 3) and what it needs around it.

``executor`` holds the step: ``Executor.judge`` gives the previous action's verdict before the frame
enters the map, ``Executor.decide`` pursues the subgoal at the pointer. Each job of a step is a collaborator
handed the step's ``context``: ``judge`` (what the previous action did), ``progress`` (the attempt, carrying
subgoals out, giving them up), ``choice`` (which instance), ``approach`` (getting there), ``search``,
``visit``, ``candidates`` and ``explore`` (finding what the map lacks), ``fronts`` (container fronts and
doors), ``detections`` (Ignore), ``motion`` (moving without collisions), ``switches`` (rows of stove
knobs), ``room`` (making room in a full receptacle), ``standin`` (another type for the one planned),
``hints`` (a commander's). ``config`` holds every budget and distance; ``state`` is what carries over
between steps, one part per concern. ``mapview`` answers Table 5's action predicates over the map and the
current frame; ``clicks`` picks the click point on an instance mask; ``success`` judges whether the
previous action worked; ``looks`` tells dirty from clean; ``sightings`` remembers container instances;
``replay`` turns an EDH history into poses.
"""

from agent.executor.clicks import Click, ClickConfig, VisibleInstance, choose_click, interior_pixel
from agent.executor.config import ExecutorConfig, SearchConfig
from agent.executor.context import StepInputs
from agent.executor.executor import Decision, Executor, ReplanReason
from agent.executor.mapview import IgnoredSpot, MapCluster, SessionMapView
from agent.executor.replay import HistoryStep, history_poses, holding_before
from agent.executor.state import ExecutorState, Hint, Verdict
from agent.executor.success import (
    FrameDigest,
    SuccessConfig,
    SuccessEstimate,
    digest,
    infer_success,
    instance_colour,
    needs_thumbnail,
)

__all__ = [
    "Click",
    "ClickConfig",
    "Decision",
    "Executor",
    "ExecutorConfig",
    "ExecutorState",
    "FrameDigest",
    "Hint",
    "HistoryStep",
    "IgnoredSpot",
    "MapCluster",
    "ReplanReason",
    "SearchConfig",
    "SessionMapView",
    "StepInputs",
    "SuccessConfig",
    "SuccessEstimate",
    "Verdict",
    "VisibleInstance",
    "choose_click",
    "digest",
    "needs_thumbnail",
    "history_poses",
    "holding_before",
    "infer_success",
    "instance_colour",
    "interior_pixel",
]
