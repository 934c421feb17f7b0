"""The action-level executor (JARVIS Algorithm 3) and what it needs around it.

``executor`` decides each step's action from the subgoal at the pointer, on top of mixins by job:
``choice`` (which instance), ``approach`` (getting there), ``search`` (finding what the map lacks),
``motion`` (moving without collisions), over the shared ``step`` context and ``config``. ``mapview``
answers Table 5's action predicates over the map and the current frame; ``clicks`` picks the click point
on an instance mask; ``success`` judges whether the previous action worked; ``looks`` tells dirty from
clean; ``replay`` turns an EDH history into poses; ``state`` is what carries over between steps.
"""

from agent.executor.clicks import Click, ClickConfig, VisibleInstance, choose_click, interior_pixel
from agent.executor.config import ExecutorConfig, SearchConfig
from agent.executor.executor import Decision, Executor
from agent.executor.mapview import IgnoredSpot, MapCluster, SessionMapView
from agent.executor.replay import HistoryStep, history_poses, holding_before
from agent.executor.state import ExecutorState, Hint
from agent.executor.step import StepInputs
from agent.executor.success import (
    FrameDigest,
    SuccessConfig,
    SuccessEstimate,
    digest,
    infer_success,
    instance_colour,
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
    "SearchConfig",
    "SessionMapView",
    "StepInputs",
    "SuccessConfig",
    "SuccessEstimate",
    "VisibleInstance",
    "choose_click",
    "digest",
    "history_poses",
    "holding_before",
    "infer_success",
    "instance_colour",
    "interior_pixel",
]
