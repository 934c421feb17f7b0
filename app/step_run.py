"""One agent step under a held session: the rules every step route keeps (DESIGN.md §4).

Both ``POST /v1/sessions/{id}/step`` and TEACh's ``POST /get_next_action`` answer through ``run_step``, so a
retry, an out-of-order request and an undecodable frame mean the same thing on either:

- a request that repeats the last answered one gets that answer again and changes nothing (a lost response
  can be retried safely);
- a request that disagrees with the session about where the episode is gets 409 before anything is decoded;
- the observation is decoded and checked completely, and perception runs, before the session changes, so a
  refused step (422) leaves it exactly as it was.

The lock itself (another request holding the session past the lock timeout → 409 ``step_in_progress``) is
the store's ``hold``; each route words that error for its own clients.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from agent.perception import ObservationError
from agent.perception.base import Observation
from agent.session import AgentSession, StepDecision
from app.metrics import ServiceMetrics, step_timing_ms
from app.observation import observation_error
from app.store import StoredSession


@dataclass(frozen=True)
class StepRules:
    """What one route's request says about where the episode is, and how to read its frame."""

    repeats_last: Callable[[AgentSession, StepDecision], bool]
    """True when the request is a retry of the last answer (given): same step index, same image name."""
    check_order: Callable[[AgentSession], None]
    """Raises a 409 ``ApiError`` when the request is not the step the session expects."""
    observe: Callable[[AgentSession], Observation]
    """Decodes and checks the request's frame for this session's camera and perception (422 otherwise)."""
    field_names: Mapping[str, str] | None = None
    """The request's names for observation fields, where they differ (TEACh's frame is ``img``)."""


@dataclass(frozen=True)
class StepRun:
    """The decision to answer with, and whether it was a retry's repeated answer."""

    decision: StepDecision
    repeated: bool


def run_step(held: StoredSession, rules: StepRules, metrics: ServiceMetrics) -> StepRun:
    """The held session's answer to one request, by the rules in the module docstring."""
    session = held.session
    last = session.last_decision
    if last is not None and rules.repeats_last(session, last):
        held.changed = False
        return StepRun(last, repeated=True)
    rules.check_order(session)
    decoding = time.perf_counter()
    observation = rules.observe(session)
    decoded = time.perf_counter()
    try:
        decision = session.step_once(observation)
    except ObservationError as error:
        raise observation_error(error, rules.field_names) from error
    held.new_frame = observation.rgb  # the live view shows it (app.live_view)
    metrics.observe_step(decoded - decoding, step_timing_ms(session, decision.step))
    return StepRun(decision, repeated=False)
