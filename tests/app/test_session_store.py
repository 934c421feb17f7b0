"""The in-memory session store: capacity, idle expiry on an injected clock, and per-session locking."""

from __future__ import annotations

import threading
import time
from datetime import UTC, datetime

import pytest
from app_support import FakeClock

from agent.geometry import Camera
from agent.planning import PlannerConfig, make_planner
from agent.session import AgentSession
from app.store import InMemorySessionStore, SessionBusy, SessionNotFound, StoreFull
from symbolic.ontology import load_ontology


def _session(session_id: str) -> AgentSession:
    planner = make_planner("oracle", load_ontology(), PlannerConfig())
    return AgentSession.start(
        session_id,
        mode="tfd",
        camera=Camera(width=32, height=24, hfov_deg=90.0),
        perception="oracle",
        navigator="fmm",
        planner=planner,
        given_subgoals="Open Fridge",
        now=datetime(2024, 5, 1, tzinfo=UTC),
    )


def test_create_beyond_capacity_raises_store_full() -> None:
    store = InMemorySessionStore(max_sessions=2, ttl_s=60.0, clock=FakeClock())
    store.create(_session("a"))
    store.create(_session("b"))

    with pytest.raises(StoreFull):
        store.create(_session("c"))
    assert store.ids() == ["a", "b"]


def test_idle_sessions_expire_and_touched_ones_survive() -> None:
    clock = FakeClock()
    store = InMemorySessionStore(max_sessions=2, ttl_s=60.0, clock=clock)
    store.create(_session("idle"))
    store.create(_session("busy"))

    clock.advance(50.0)
    store.touch("busy")
    clock.advance(11.0)

    assert store.ids() == ["busy"]
    with pytest.raises(SessionNotFound):
        store.get("idle")
    store.create(_session("new"))  # the evicted session's slot is free again
    assert len(store) == 2


def test_a_held_session_is_busy_for_others() -> None:
    store = InMemorySessionStore(max_sessions=2, ttl_s=60.0, clock=FakeClock())
    store.create(_session("a"))

    with store.hold("a", timeout_s=1.0), pytest.raises(SessionBusy), store.hold("a", timeout_s=0.05):
        pass
    with store.hold("a", timeout_s=0.05) as session:
        assert session.session_id == "a"


def test_two_threads_holding_one_session_never_interleave() -> None:
    store = InMemorySessionStore(max_sessions=2, ttl_s=60.0)
    store.create(_session("a"))
    events: list[str] = []

    def work(name: str) -> None:
        for _ in range(5):
            with store.hold("a", timeout_s=5.0):
                events.append(f"enter {name}")
                time.sleep(0.002)
                events.append(f"exit {name}")

    threads = [threading.Thread(target=work, args=(name,)) for name in ("x", "y")]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()

    assert len(events) == 20
    for enter, leave in zip(events[::2], events[1::2], strict=True):
        assert enter.startswith("enter") and leave == enter.replace("enter", "exit"), events
