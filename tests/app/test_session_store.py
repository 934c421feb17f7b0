"""The session stores: the same contract in memory and in a real Redis (capacity, owners, names, exclusive
holds), and what only Redis must do: two stores on one server (two workers) see each other's writes, a
failed block stores nothing, a dead worker's lease lapses, a request that outlived its lease stores
nothing."""

from __future__ import annotations

import shutil
import socket
import subprocess
import threading
import time
from collections.abc import Callable, Iterator
from datetime import UTC, datetime
from pathlib import Path

import pytest
import redis
from app_support import SMALL_CAMERA, FakeClock
from fastapi.testclient import TestClient

from agent.geometry import Camera
from agent.planning import PlannerConfig, make_planner
from agent.session import AgentSession, SessionSpec
from agent.trace import TraceEntry
from app.keys import hash_key
from app.redis_store import LeaseLost, RedisSessionStore
from app.store import (
    InMemorySessionStore,
    SessionBusy,
    SessionNotFound,
    SessionStore,
    StoredSession,
    StoreFull,
)
from symbolic.ontology import load_ontology

ONTOLOGY = load_ontology()


def _session(session_id: str) -> AgentSession:
    planner = make_planner("oracle", ONTOLOGY, PlannerConfig())
    return AgentSession.start(
        session_id,
        SessionSpec("tfd", Camera(width=32, height=24, hfov_deg=90.0), "oracle", "fmm"),
        planner,
        given_subgoals="Open Fridge",
        ontology=ONTOLOGY,
        now=datetime(2024, 5, 1, tzinfo=UTC),
    )


MakeStore = Callable[..., SessionStore]


@pytest.fixture(params=["memory", "redis"])
def make_store(request: pytest.FixtureRequest) -> Iterator[MakeStore]:
    """``make_store(max_sessions=2, ttl_s=60.0, lease_s=5.0)``: a new store of the parametrized kind; Redis
    stores made in one test share their keys, as worker processes do."""
    made: list[SessionStore] = []
    prefix = request.getfixturevalue("redis_prefix") if request.param == "redis" else ""
    url = request.getfixturevalue("redis_url") if request.param == "redis" else ""

    def make(max_sessions: int = 2, ttl_s: float = 60.0, lease_s: float = 5.0) -> SessionStore:
        store: SessionStore
        if request.param == "memory":
            store = InMemorySessionStore(max_sessions, ttl_s, clock=FakeClock())
        else:
            store = RedisSessionStore(
                url, max_sessions=max_sessions, ttl_s=ttl_s, lease_s=lease_s, ontology=ONTOLOGY, prefix=prefix
            )
        made.append(store)
        return store

    yield make
    for store in made:
        store.close()


def test_create_beyond_capacity_raises_store_full_with_a_wait(make_store: MakeStore) -> None:
    store = make_store(max_sessions=2)
    store.create(StoredSession(_session("a"), None))
    store.create(StoredSession(_session("b"), None))

    with pytest.raises(StoreFull) as full:
        store.create(StoredSession(_session("c"), None))
    assert store.ids(None) == ["a", "b"]
    assert not full.value.per_owner and 1.0 <= full.value.retry_after_s <= 60.0


def test_an_owner_at_its_cap_is_refused_while_others_still_create(make_store: MakeStore) -> None:
    store = make_store(max_sessions=10)
    store.create(StoredSession(_session("a1"), "alice"), owner_cap=2)
    store.create(StoredSession(_session("a2"), "alice"), owner_cap=2)

    with pytest.raises(StoreFull) as full:
        store.create(StoredSession(_session("a3"), "alice"), owner_cap=2)
    store.create(StoredSession(_session("b1"), "bob"), owner_cap=2)

    assert full.value.per_owner and full.value.capacity == 2
    assert store.ids("alice") == ["a1", "a2"] and store.ids("bob") == ["b1"]
    assert store.ids(None) == ["a1", "a2", "b1"]


def test_another_owner_finds_no_session(make_store: MakeStore) -> None:
    store = make_store()
    store.create(StoredSession(_session("a"), "alice"))

    with pytest.raises(SessionNotFound), store.hold("a", "bob", 1.0, write=False):
        pass
    with pytest.raises(SessionNotFound):
        store.delete("a", "bob")
    with pytest.raises(SessionNotFound), store.hold("a", None, 1.0, write=False):
        pass
    with store.hold("a", "alice", 1.0, write=False) as held:
        assert held.session.session_id == "a" and held.owner == "alice"


def test_names_belong_to_their_owner_and_replace_in_order(make_store: MakeStore) -> None:
    store = make_store()
    assert store.bind_name("alice", "edh/1.json", "s1") is None
    assert store.bind_name("bob", "edh/1.json", "s2") is None  # the same name, another key: its own
    assert store.bind_name("alice", "edh/2.json", "s3") is None
    assert store.bind_name("alice", "edh/1.json", "s4") == "s1"

    assert store.named("alice", "edh/1.json") == "s4" and store.named("bob", "edh/1.json") == "s2"
    assert store.names("alice") == [("edh/2.json", "s3"), ("edh/1.json", "s4")]
    store.unbind_name("alice", "edh/2.json")
    assert store.names("alice") == [("edh/1.json", "s4")] and store.named("alice", "edh/2.json") is None


def test_a_held_session_is_busy_for_others(make_store: MakeStore) -> None:
    store = make_store()
    store.create(StoredSession(_session("a"), None))

    with store.hold("a", None, 1.0, write=False), pytest.raises(SessionBusy):  # noqa: SIM117
        with store.hold("a", None, 0.05, write=False):
            pass
    with store.hold("a", None, 0.05, write=False) as held:
        assert held.session.session_id == "a"


def test_two_threads_holding_one_session_never_interleave(make_store: MakeStore) -> None:
    store = make_store()
    store.create(StoredSession(_session("a"), None))
    events: list[str] = []

    def work(name: str) -> None:
        for _ in range(5):
            with store.hold("a", None, 5.0, write=True):
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


def test_finished_says_done_or_gone(make_store: MakeStore) -> None:
    store = make_store()
    store.create(StoredSession(_session("a"), None))
    assert not store.finished("a") and store.finished("never")
    with store.hold("a", None, 1.0, write=True) as held:
        held.session.done = True
    assert store.finished("a")


def test_in_memory_idle_sessions_expire_and_used_ones_survive() -> None:
    clock = FakeClock()
    store = InMemorySessionStore(max_sessions=2, ttl_s=60.0, clock=clock)
    store.create(StoredSession(_session("idle"), None))
    store.create(StoredSession(_session("busy"), None))

    clock.advance(50.0)
    with store.hold("busy", None, 1.0, write=False):
        pass
    clock.advance(11.0)

    assert store.ids(None) == ["busy"]
    with pytest.raises(SessionNotFound), store.hold("idle", None, 1.0, write=False):
        pass
    store.create(StoredSession(_session("new"), None))  # the evicted session's slot is free again
    assert len(store) == 2


# ----- Redis only -------------------------------------------------------------------------------------


@pytest.fixture
def two_workers(redis_url: str, redis_prefix: str) -> Iterator[tuple[RedisSessionStore, RedisSessionStore]]:
    """Two stores on one Redis, as two worker processes hold them (each with its own decoded copies)."""
    stores = tuple(
        RedisSessionStore(
            redis_url, max_sessions=4, ttl_s=60.0, lease_s=1.0, ontology=ONTOLOGY, prefix=redis_prefix
        )
        for _ in range(2)
    )
    yield stores[0], stores[1]
    for store in stores:
        store.close()


def test_redis_a_write_through_one_worker_is_what_the_other_reads(
    two_workers: tuple[RedisSessionStore, RedisSessionStore],
) -> None:
    first, second = two_workers
    first.create(StoredSession(_session("a"), None, {"note": 1}))
    with second.hold("a", None, 1.0, write=True) as held:  # the second worker loads it, and changes it
        held.session.step = 7
        held.meta["note"] = 2
    with first.hold("a", None, 1.0, write=False) as held:  # the first's copy is stale: it loads again
        assert held.session.step == 7 and held.meta == {"note": 2}


def test_redis_a_session_loaded_by_another_worker_has_every_trace_line(
    two_workers: tuple[RedisSessionStore, RedisSessionStore],
) -> None:
    """Snapshots leave the trace out (the trace's sorted set holds it); the worker that loads a session
    gets its lines back from there, so the session's own view shows what the other worker wrote."""
    first, second = two_workers
    first.create(StoredSession(_session("a"), None))
    for step in range(3):
        with first.hold("a", None, 1.0, write=True) as held:
            held.session.trace.append(_trace_entry(step))
    written = list(_session_of(first, "a").trace.lines())

    loaded = _session_of(second, "a")

    assert len(written) == 3 and list(loaded.trace.lines()) == written
    assert loaded.trace.nbytes == sum(len(line) for line in written)


def _trace_entry(step: int) -> TraceEntry:
    return TraceEntry(
        step,
        "2024-05-01T00:00:00+00:00",
        {},
        None,
        None,
        "",
        {},
        {},
        None,
        0,
        "RotateLeft",
        None,
        None,
        "test",
    )


def _session_of(store: RedisSessionStore, session_id: str) -> AgentSession:
    with store.hold(session_id, None, 1.0, write=False) as held:
        return held.session


def test_redis_a_block_that_raises_stores_nothing(
    two_workers: tuple[RedisSessionStore, RedisSessionStore],
) -> None:
    first, second = two_workers
    first.create(StoredSession(_session("a"), None))
    with pytest.raises(RuntimeError), first.hold("a", None, 1.0, write=True) as held:
        held.session.step = 99
        raise RuntimeError("the step failed half way")
    for store in (first, second):
        with store.hold("a", None, 1.0, write=False) as held:
            assert held.session.step == 0


def test_redis_idle_sessions_expire_on_redis_clock(redis_url: str, redis_prefix: str) -> None:
    store = RedisSessionStore(
        redis_url, max_sessions=2, ttl_s=0.5, lease_s=1.0, ontology=ONTOLOGY, prefix=redis_prefix
    )
    store.create(StoredSession(_session("a"), None))
    store.create(StoredSession(_session("b"), None))
    time.sleep(0.7)

    assert store.ids(None) == [] and len(store) == 0
    store.create(StoredSession(_session("c"), None))  # the expired sessions' slots are free again
    with pytest.raises(SessionNotFound), store.hold("a", None, 1.0, write=False):
        pass
    store.close()


def test_redis_a_dead_workers_lease_lapses(
    two_workers: tuple[RedisSessionStore, RedisSessionStore], redis_url: str, redis_prefix: str
) -> None:
    """A worker killed while holding a session leaves its lease; after ``lease_s`` another worker goes on."""
    first, second = two_workers
    first.create(StoredSession(_session("a"), None))
    redis.Redis.from_url(redis_url).set(f"{redis_prefix}:lease:a", "dead-worker", px=1000)

    with pytest.raises(SessionBusy), second.hold("a", None, 0.2, write=False):
        pass
    started = time.monotonic()
    with second.hold("a", None, 3.0, write=True) as held:
        held.session.step = 1
    assert 0.5 < time.monotonic() - started < 2.0


def test_redis_a_working_worker_keeps_its_lease_past_lease_s(
    two_workers: tuple[RedisSessionStore, RedisSessionStore],
) -> None:
    first, second = two_workers
    first.create(StoredSession(_session("a"), None))
    with first.hold("a", None, 1.0, write=True) as slow:
        slow.session.step = 5
        time.sleep(1.5)  # past its 1 s lease: renewed while it works
        with pytest.raises(SessionBusy), second.hold("a", None, 0.2, write=False):
            pass
    with second.hold("a", None, 1.0, write=False) as held:
        assert held.session.step == 5


def test_redis_a_request_whose_lease_was_taken_over_stores_nothing(
    two_workers: tuple[RedisSessionStore, RedisSessionStore], redis_url: str, redis_prefix: str
) -> None:
    """A worker that stalled past its lease (no renewal reached Redis) and lost the session to another
    must not overwrite what the other stored."""
    first, second = two_workers
    first.create(StoredSession(_session("a"), None))
    with pytest.raises(LeaseLost), first.hold("a", None, 1.0, write=True) as stalled:
        stalled.session.step = 5
        redis.Redis.from_url(redis_url).set(f"{redis_prefix}:lease:a", "another-worker", px=1000)
    with second.hold("a", None, 2.0, write=False) as held:
        assert held.session.step == 0


@pytest.fixture
def own_redis(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[str, subprocess.Popen[bytes]]]:
    """A redis-server of this test's own, which the test may stop (the shared one must stay up)."""
    binary = shutil.which("redis-server")
    if binary is None:
        pytest.skip("no redis-server binary on PATH to start a Redis this test may stop")
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    server = subprocess.Popen(
        [binary, "--port", str(port), "--bind", "127.0.0.1", "--save", "", "--appendonly", "no"],
        cwd=tmp_path_factory.mktemp("own-redis"),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    url = f"redis://127.0.0.1:{port}/0"
    deadline = time.monotonic() + 10.0
    while True:
        try:
            redis.Redis.from_url(url).ping()
            break
        except redis.RedisError:
            assert time.monotonic() < deadline and server.poll() is None, "redis-server did not start"
            time.sleep(0.05)
    yield url, server
    server.kill()
    server.wait(timeout=10)


def test_a_store_that_stops_answering_is_a_503_to_retry_and_not_ready(
    own_redis: tuple[str, subprocess.Popen[bytes]], make_client: Callable[..., TestClient]
) -> None:
    url, server = own_redis
    client = make_client(store=url, api_keys=f"alice:{hash_key('alice-key')}")
    headers = {"Authorization": "Bearer alice-key"}
    created = client.post(
        "/v1/sessions",
        json={"mode": "tfd", "subgoals": "Open Fridge", "camera": SMALL_CAMERA},
        headers=headers,
    )
    assert created.status_code == 201 and client.get("/readyz").status_code == 200
    server.kill()
    server.wait(timeout=10)

    read = client.get(f"/v1/sessions/{created.json()['session_id']}", headers=headers)
    listed = client.get("/v1/sessions", headers=headers)  # the key check's rate limiter asks Redis first
    ready = client.get("/readyz")

    for refused in (read, listed):
        assert refused.status_code == 503, refused.text
        assert refused.json()["error"] == "store_unavailable" and refused.headers["Retry-After"] == "1"
    assert ready.status_code == 503 and "session store" in ready.json()["detail"]


def test_redis_a_hold_that_changed_nothing_writes_no_new_snapshot(
    two_workers: tuple[RedisSessionStore, RedisSessionStore], redis_url: str, redis_prefix: str
) -> None:
    """A retried step is answered again without storing the same state again."""
    first, second = two_workers
    first.create(StoredSession(_session("a"), None))
    version = redis.Redis.from_url(redis_url).hget(f"{redis_prefix}:s:a", "ver")
    with first.hold("a", None, 1.0, write=True) as held:
        held.changed = False
    with second.hold("a", None, 1.0, write=True) as held:
        held.session.step = 3

    assert version == b"1"
    assert redis.Redis.from_url(redis_url).hget(f"{redis_prefix}:s:a", "ver") == b"2"


def test_redis_a_loaded_session_plans_and_perceives_with_the_loading_services_configuration(
    redis_url: str, redis_prefix: str
) -> None:
    """What a snapshot names (a planner, network paths) is resolved by the worker that loads it, with its
    own settings: a stored path never picks the checkpoints a worker uses."""
    from agent.perception import NetworkPaths

    first = RedisSessionStore(
        redis_url, max_sessions=2, ttl_s=60.0, lease_s=1.0, ontology=ONTOLOGY, prefix=redis_prefix
    )
    configured = NetworkPaths(depth=Path("/srv/models/depth"), segmentation=Path("/srv/models/seg"))
    second = RedisSessionStore(
        redis_url,
        max_sessions=2,
        ttl_s=60.0,
        lease_s=1.0,
        ontology=ONTOLOGY,
        prefix=redis_prefix,
        planners=lambda name: make_planner(name, ONTOLOGY, PlannerConfig(max_subgoals=7)),
        networks=configured,
    )
    first.create(StoredSession(_session("a"), None))

    with second.hold("a", None, 1.0, write=False) as held:
        assert held.session.planner.config.max_subgoals == 7  # type: ignore[attr-defined]
        assert held.session.spec.networks == configured
    first.close()
    second.close()
