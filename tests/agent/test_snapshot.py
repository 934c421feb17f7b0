"""Session snapshots (agent/snapshot.py): a restored session decides as the original would, what the graph
shares stays shared, and bytes that are not a snapshot this build reads are refused with SnapshotError."""

from __future__ import annotations

import ast
import inspect
import json
import struct
import sys
import zlib
from collections import deque
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

import msgpack
import numpy as np
import pytest
from executor_support import execute, kitchen, observation, oracle_session, simulator, step_through

import agent.session
import agent.snapshot
from agent.exploration_gt import GoalTransformerExplorer
from agent.geometry import Camera, Pose
from agent.navigation.exploration import FrontierExplorer
from agent.planning import make_planner
from agent.session import AgentSession
from agent.snapshot import FORMAT_VERSION, MAGIC, Name, SnapshotError, Tag, dumps, loads
from agent.trace import Trace
from harness.sim.simulator import Simulator
from symbolic.ontology import load_ontology
from symbolic.subgoals import Subgoal, SubgoalAction

CAMERA = Camera(300, 300, 90.0)
SEARCH_STEPS = 30
"""Steps of a search for a kettle the kitchen lacks: the explorer, the map and the sightings fill up."""


def _searching(navigator: str, explorer: str) -> tuple[AgentSession, Simulator]:
    """A session ``SEARCH_STEPS`` into a search with a live explorer, and its simulator."""
    session = oracle_session("Navigate Kettle, Pickup Kettle", navigator=navigator, explorer=explorer)
    sim = simulator(kitchen())
    assert not sim.world.of_type("Kettle")
    step_through(session, sim, SEARCH_STEPS)
    attempt = session.executor.state.attempt
    assert attempt is not None and attempt.search.explorer is not None, "the search has no explorer"
    return session, sim


@pytest.fixture(
    scope="module", params=[("fmm", "frontier"), ("vin", "frontier"), ("fmm", "goal_transformer")]
)
def searching(request: pytest.FixtureRequest) -> tuple[AgentSession, Simulator]:
    return _searching(*request.param)


def test_a_restored_session_decides_as_the_original_step_after_step(
    searching: tuple[AgentSession, Simulator],
) -> None:
    session, sim = searching
    restored = AgentSession.from_bytes(session.to_bytes())
    for step in range(3):
        upcoming = observation(sim.observe(noise_seed=100 + step), sim.world.agent)
        decision = session.step_once(upcoming)
        assert restored.step_once(upcoming) == decision, f"decision {step} after loading differs"
        execute(sim, decision.action, decision.x, decision.y)
    assert len(restored.trace) == len(session.trace)  # the lines differ in their timings


def test_a_snapshot_without_its_trace_is_smaller_and_loads_only_with_the_trace_given(
    searching: tuple[AgentSession, Simulator],
) -> None:
    """A shared store keeps the trace lines itself, so its snapshots leave them out; loading one takes the
    trace from the caller, and refuses to invent an empty one."""
    session, _ = searching
    full, lean = session.to_bytes(), session.to_bytes(with_trace=False)
    kept = Trace.from_lines((int(json.loads(line)["step"]), line) for line in session.trace.lines())

    restored = AgentSession.from_bytes(lean, trace=kept)

    assert len(lean) < len(full)
    assert restored.trace is kept and list(kept.lines()) == list(session.trace.lines())
    with pytest.raises(SnapshotError, match="without its trace"):
        AgentSession.from_bytes(lean)


def test_what_the_session_shares_is_shared_after_loading(searching: tuple[AgentSession, Simulator]) -> None:
    session, _ = searching
    restored = AgentSession.from_bytes(session.to_bytes())
    executor = restored.executor
    attempt = executor.state.attempt
    assert attempt is not None
    explorer = attempt.search.explorer
    assert explorer is not None and explorer._rng is executor.rng
    if isinstance(explorer, FrontierExplorer):
        assert explorer._navigator is executor.navigator
    assert restored.last_decision is not None
    assert all(a is b for a, b in zip(restored.last_decision.repair_log, restored.repair_log, strict=False))
    assert restored.ontology is executor.ontology


def test_process_wide_parts_are_named_not_stored(searching: tuple[AgentSession, Simulator]) -> None:
    """The ontology, the planner and the models come from the loading process; the goal transformer's
    weights (megabytes) are not in the snapshot."""
    session, _ = searching
    ontology, planner = load_ontology(), make_planner("oracle", load_ontology())
    snapshot = session.to_bytes()
    restored = AgentSession.from_bytes(snapshot, ontology=ontology, planner=planner)
    assert restored.ontology is ontology and restored.planner is planner
    assert restored.perception_backend is not session.perception_backend
    assert len(snapshot) < 200_000, len(snapshot)
    attempt = restored.executor.state.attempt
    assert attempt is not None
    if isinstance(attempt.search.explorer, GoalTransformerExplorer):
        original = session.executor.state.attempt
        assert original is not None and isinstance(original.search.explorer, GoalTransformerExplorer)
        assert attempt.search.explorer._policy is original.search.explorer._policy  # one per process


@dataclass
class _Holder:
    """A class of the tests: not in the allowlist."""

    value: int = 0


def _roundtrip(value: object) -> object:
    def no_names(name: Name) -> object:
        raise AssertionError(f"nothing is named here, got {name}")

    return loads(dumps(value), no_names)


VALUES: list[object] = [
    None,
    True,
    -(2**63),
    2**64 - 1,
    2**130,
    -(2**70),
    1.5,
    float("inf"),
    "text \udc80 with a lone surrogate",
    b"\x00bytes",
    [1, [2, "x"]],
    (1, (2.0, None)),
    {3, 4},
    frozenset({"a", "b"}),
    {"k": [1], "": {}},
    {(1, 2): "tuple key", 3: "int key"},
    deque([1, 2, 3], maxlen=5),
    deque(["unbounded"]),
    datetime(2026, 12, 7, 3, 4, 5, 6, tzinfo=UTC),
    Path("/some/checkpoint"),
    SubgoalAction.PICKUP,
    Subgoal(SubgoalAction.PICKUP, "Knife"),
    Pose(1.0, 2.0, 90.0, 30.0),
    np.float32(0.25),
    np.int64(-7),
    np.bool_(True),
]


@pytest.mark.parametrize("value", VALUES, ids=lambda v: type(v).__name__)
def test_values_of_every_kind_load_equal_and_of_the_same_type(value: object) -> None:
    loaded = _roundtrip(value)
    assert loaded == value and type(loaded) is type(value)
    if isinstance(value, deque):
        assert isinstance(loaded, deque) and loaded.maxlen == value.maxlen


@pytest.mark.parametrize(
    "array",
    [
        np.arange(24, dtype=np.float32).reshape(2, 3, 4),
        np.arange(24, dtype=np.uint8).reshape(2, 3, 4).transpose(1, 2, 0),  # not C-contiguous
        np.zeros((0, 3), dtype=np.int16),
        np.array(5, dtype=np.int32),
        np.array([True, False]),
        np.array([1 + 2j], dtype=np.complex64),
    ],
    ids=["float32", "transposed", "empty", "0-d", "bool", "complex"],
)
def test_arrays_load_equal_with_their_dtype_and_shape_and_writable(array: np.ndarray) -> None:
    loaded = _roundtrip(array)
    assert isinstance(loaded, np.ndarray)
    assert loaded.dtype == array.dtype and loaded.shape == array.shape and np.array_equal(loaded, array)
    assert loaded.flags.writeable


def test_a_random_generator_continues_where_it_was() -> None:
    rng = np.random.default_rng(3)
    rng.random(10)
    loaded = _roundtrip(rng)
    assert isinstance(loaded, np.random.Generator)
    assert np.array_equal(loaded.random(5), rng.random(5))


def test_shared_objects_and_cycles_keep_their_identity() -> None:
    shared = [1, 2]
    cyclic: list[object] = ["me"]
    cyclic.append(cyclic)
    pose = Pose(0.0, 0.0)
    loaded = _roundtrip({"a": shared, "b": shared, "c": cyclic, "poses": (pose, pose)})
    assert isinstance(loaded, dict)
    assert loaded["a"] is loaded["b"] and loaded["a"] == [1, 2]
    assert loaded["c"][1] is loaded["c"]
    assert loaded["poses"][0] is loaded["poses"][1]


@pytest.mark.parametrize(
    "value",
    [_Holder(), [object()], np.array([None, 1], dtype=object), {"nested": [_Holder()]}],
    ids=["dataclass", "object", "object-array", "nested"],
)
def test_saving_refuses_what_the_allowlist_does_not_name(value: object) -> None:
    with pytest.raises(SnapshotError, match=r"cannot snapshot"):
        dumps(value)


def _container(body: object, version: int = FORMAT_VERSION) -> bytes:
    return struct.pack(">8sH", MAGIC, version) + zlib.compress(msgpack.packb(body))


def test_a_snapshot_of_another_format_version_is_refused_naming_both_versions() -> None:
    snapshot = _container([[], None], version=FORMAT_VERSION + 1)
    with pytest.raises(SnapshotError, match=rf"version {FORMAT_VERSION + 1}.*version {FORMAT_VERSION}"):
        AgentSession.from_bytes(snapshot)


def test_a_snapshot_naming_a_class_outside_the_allowlist_is_refused() -> None:
    crafted = _container([["os.system"], [Tag.OBJECT, 0, {}]])
    with pytest.raises(SnapshotError, match=r"os\.system"):
        AgentSession.from_bytes(crafted)


@pytest.mark.parametrize(
    "body",
    [
        [[], [Tag.REF, 0]],  # a reference to nothing
        [[], [99, 1]],  # no such kind
        [[], [Tag.ARRAY, "|O", [1], b"\x00" * 8]],  # an object array
        [[], [Tag.ARRAY, "<f4", [1000], b"\x00" * 4]],  # bytes short of the shape
        [[], [Tag.GENERATOR, "RandomState", {}]],  # not an allowed bit generator
        [[], [Tag.NAMED, "os", "system"]],  # no such process-wide object
        [["agent.geometry.Pose"], [Tag.OBJECT, 1, {}]],  # no such class number
        [["agent.geometry.Pose"], [Tag.ENUM, 0, "x"]],  # a dataclass as an enum
        [["symbolic.subgoals.SubgoalAction"], [Tag.ENUM, 0, "Fly"]],  # no such member
        [[], [Tag.SEMANTIC_MAP, b"JSM1garbage"]],
        {"not": "a body"},
    ],
)
def test_a_crafted_body_is_refused_with_snapshot_error(body: object) -> None:
    with pytest.raises(SnapshotError):
        AgentSession.from_bytes(_container(body))


def test_a_snapshot_that_holds_no_session_is_refused() -> None:
    with pytest.raises(SnapshotError, match="not a session"):
        AgentSession.from_bytes(dumps([1, 2]))


def test_truncated_or_garbage_bytes_are_refused_with_snapshot_error_only() -> None:
    """Every failure to read untrusted bytes is a SnapshotError (pytest.raises lets other types through)."""
    snapshot = _small_session(steps=5).to_bytes()
    header = struct.calcsize(">8sH")
    flipped = bytearray(snapshot)
    flipped[header + len(snapshot) // 2] ^= 0xFF
    broken = [
        b"",
        snapshot[:5],
        snapshot[:header],
        snapshot[: len(snapshot) // 2],
        snapshot[:-1],
        bytes(flipped),
        zlib.compress(b"an old pickle snapshot started like this"),
        MAGIC + struct.pack(">H", FORMAT_VERSION) + b"\x00" * 64,
        MAGIC + struct.pack(">H", FORMAT_VERSION) + zlib.compress(b"\xc1 not msgpack"),
        MAGIC + struct.pack(">H", FORMAT_VERSION) + zlib.compress(b"\x00" * 100_000_000),  # a zlib bomb
    ]
    for data in broken:
        with pytest.raises(SnapshotError):
            AgentSession.from_bytes(data)


def _small_session(steps: int = 0) -> AgentSession:
    """A session ``steps`` into fetching an apple."""
    session = oracle_session("Navigate Apple, Pickup Apple")
    step_through(session, simulator(kitchen()), steps)
    return session


def test_loading_a_snapshot_never_uses_pickle() -> None:
    """Neither module of the snapshot path imports pickle, and loading resolves no class through it."""
    for module in (agent.snapshot, agent.session):
        tree = ast.parse(inspect.getsource(module))
        imported = {
            alias.name.split(".")[0]
            for node in ast.walk(tree)
            if isinstance(node, ast.Import | ast.ImportFrom)
            for alias in (node.names if isinstance(node, ast.Import) else [ast.alias(node.module or "")])
        }
        assert "pickle" not in imported and "pickle" not in vars(module), module.__name__
    found: list[object] = []
    listening = [True]

    def hook(event: str, args: tuple[object, ...]) -> None:
        if listening[0] and event == "pickle.find_class":
            found.append(args)

    sys.addaudithook(hook)  # hooks cannot be removed; this one stops listening below
    try:
        AgentSession.from_bytes(_small_session(steps=2).to_bytes())
    finally:
        listening[0] = False
    assert not found, f"loading unpickled {found}"
