"""Session snapshots: a versioned, self-describing encoding of a session's object graph that loads without
running code.

Why not pickle: a snapshot travels through a shared store (Redis, DESIGN.md §9), and what a shared store
hands back is untrusted; unpickling runs whatever callables the bytes name. Here loading only builds
values of known kinds, and instances of the classes in ``allowed_classes`` (made with ``object.__new__``
and given their attributes, so no constructor runs); a snapshot naming any other class is refused.

Container: ``MAGIC`` (8 bytes), ``FORMAT_VERSION`` (uint16, big-endian), then the zlib-compressed msgpack
body ``[class names, root node]``. A node is a msgpack native (None, bool, a 64-bit int, float, str, bytes),
a map (a dict whose keys are all str), or a list whose first item is a ``Tag`` saying what the rest holds.
Every mutable object, instance and named object is numbered in the order it is first met (depth first,
before its contents), and met again it is a ``REF`` to that number: what the graph shares (the explorer's
navigator *is* the executor's) stays shared after loading, and cycles load. Process-wide objects (the
ontology, the planner, the perception back-end, the goal transformer) are not stored but ``NAMED``: the
caller says which objects have names when saving, and resolves the names when loading. The semantic map
is stored in its own compact format (``SemanticMap.to_bytes``: its voxel grid compresses to a few KB).
"""

from __future__ import annotations

import enum
import functools
import struct
import zlib
from collections import deque
from collections.abc import Callable, Mapping
from datetime import datetime
from pathlib import Path, PurePath
from typing import Any

import msgpack
import numpy as np

from agent.executor.clicks import Click, ClickConfig
from agent.executor.config import ExecutorConfig, SearchConfig
from agent.executor.executor import Executor
from agent.executor.looks import StainConfig
from agent.executor.mapview import IgnoredSpot
from agent.executor.state import (
    Attempt,
    ContainerVisit,
    Detections,
    ExecutorState,
    FailedClick,
    Hint,
    Memory,
    MotionMemory,
    Pending,
    Progress,
    RowProgress,
    SearchMemory,
    SearchState,
    Sighting,
)
from agent.executor.success import FrameDigest, SuccessConfig
from agent.exploration_gt import GoalExplorerConfig, GoalTransformerExplorer, _Search
from agent.geometry import Camera, Pose
from agent.mapping import SemanticMap
from agent.navigation.exploration import ExplorationConfig, FrontierExplorer
from agent.navigation.fmm import FmmConfig, FmmNavigator
from agent.navigation.vin import VinConfig, VinNavigator
from agent.perception.base import HandRegion
from agent.perception.learned import NetworkPaths
from agent.planning import DialogueTurn
from agent.trace import Trace
from symbolic.belief import BeliefState
from symbolic.repair import RepairEvent
from symbolic.subgoals import Subgoal, SubgoalAction

MAGIC = b"JARVSNAP"
FORMAT_VERSION = 4
"""Bump on any change to the layout or the meaning of a node; older snapshots are then refused, not
mis-read (a session restarts rather than resumes from a state it would misunderstand)."""
_HEADER = struct.Struct(">8sH")
ZLIB_LEVEL = 1
"""Measured on a kitchen session after 80 steps (a 101 KB body): level 1 gives 23.8 KB in 0.47 ms, level 6
20.6 KB in 1.45 ms. The service writes a snapshot after every step, so 13% fewer bytes are not worth three
times the time (the map inside is compressed already, by ``SemanticMap.to_bytes``)."""
MAX_BODY_BYTES = 64 * 1024 * 1024
"""Uncompressed body size refused on loading (a zlib bomb); a session's is about 100 KB (DESIGN.md §8
allows 2 MB of state)."""
_INT_MIN, _INT_MAX = -(2**63), 2**64 - 1
"""msgpack's integer range; larger ints (a PCG64 state is 128 bits) travel as decimal strings."""
_BIT_GENERATORS: dict[str, type[np.random.BitGenerator]] = {
    cls.__name__: cls
    for cls in (np.random.PCG64, np.random.PCG64DXSM, np.random.Philox, np.random.SFC64, np.random.MT19937)
}
_ARRAY_KINDS = frozenset("biufc")
"""numpy dtype kinds stored (bool, ints, floats, complex): raw bytes, never objects."""

Name = tuple[str, ...]
"""A process-wide object's name in a snapshot, e.g. ("planner", "oracle")."""


class SnapshotError(ValueError):
    """The bytes are not a snapshot this build can load, or the object graph holds what it cannot store."""


class Tag(enum.IntEnum):
    """First item of a list node: what the rest of the list holds."""

    REF = 0  # [REF, number]: an object met before
    LIST = 1  # [LIST, *items]
    TUPLE = 2  # [TUPLE, *items]
    SET = 3  # [SET, *items]
    FROZENSET = 4  # [FROZENSET, *items]
    DICT = 5  # [DICT, key, value, key, value, ...]: keys that are not all str
    DEQUE = 6  # [DEQUE, maxlen, *items]
    DATETIME = 7  # [DATETIME, ISO 8601 text]
    PATH = 8  # [PATH, text]
    ENUM = 9  # [ENUM, class number, value]
    ARRAY = 10  # [ARRAY, dtype text, shape, bytes]: C order
    SCALAR = 11  # [SCALAR, dtype text, bytes]: a numpy scalar
    GENERATOR = 12  # [GENERATOR, bit generator name, its state]
    OBJECT = 13  # [OBJECT, class number, {attribute: node}]
    NAMED = 14  # [NAMED, *name]: a process-wide object
    SEMANTIC_MAP = 15  # [SEMANTIC_MAP, SemanticMap.to_bytes()]
    BIGINT = 16  # [BIGINT, decimal text]


_CLASSES: tuple[type, ...] = (
    # the session's parts (agent.session's own classes are added by ``allowed_classes``)
    Camera, Pose, DialogueTurn, Trace, NetworkPaths, HandRegion, SuccessConfig, FrameDigest, Subgoal,
    SubgoalAction, RepairEvent,
    # the executor and what it carries between steps
    Executor, ExecutorConfig, SearchConfig, ClickConfig, StainConfig, ExecutorState, BeliefState, Memory,
    SearchMemory, Detections, MotionMemory, Progress, Hint, Attempt, SearchState, RowProgress, ContainerVisit,
    Pending, FailedClick, Click, IgnoredSpot, Sighting,
    # navigation and exploration
    FmmNavigator, FmmConfig, VinNavigator, VinConfig, FrontierExplorer, ExplorationConfig,
    GoalTransformerExplorer, GoalExplorerConfig, _Search,
)  # fmt: skip

_DETACHED: dict[type, dict[str, Callable[[Any], Name]]] = {
    GoalTransformerExplorer: {"_policy": lambda owner: ("goal_policy", str(owner.config.checkpoint))},
}
"""Attributes holding process-wide objects that only their owner reaches, stored as the name the owner
gives them: the goal transformer (a torch model loaded once per process) by its checkpoint directory."""


@functools.cache
def allowed_classes() -> dict[str, type]:
    """The classes a session snapshot may hold, by ``module.qualname``: the session's dataclasses, the few
    plain classes of its graph, and the enums. A class outside it is refused both ways, so a new field of
    a new type fails a test instead of being stored unchecked (or, worse, loaded from untrusted bytes)."""
    from agent.session import (  # imports us
        AgentSession,
        FrameAlignment,
        SessionLimits,
        SessionSpec,
        StepDecision,
    )

    session = (AgentSession, SessionSpec, SessionLimits, StepDecision, FrameAlignment)
    return {_class_name(cls): cls for cls in (*session, *_CLASSES)}


def dumps(root: object, named: Mapping[int, Name] | None = None) -> bytes:
    """The snapshot of the graph from ``root``; ``named`` maps ``id()`` of process-wide objects to names.

    Raises SnapshotError for a value it cannot store (a class outside ``allowed_classes``, an object array).
    """
    body = zlib.compress(_pack(root, named or {}), ZLIB_LEVEL)
    return _HEADER.pack(MAGIC, FORMAT_VERSION) + body


def encoded_size(root: object) -> int:
    """Bytes the graph from ``root`` takes in a snapshot body before compression (a cheap size measure)."""
    return len(_pack(root, {}))


def loads(data: bytes, resolve: Callable[[Name], object]) -> object:
    """The graph ``dumps`` wrote, with ``resolve(name)`` for each named object.

    Raises SnapshotError, and nothing else, for whatever the bytes are if not a snapshot of this format
    version holding only allowed classes: they come from a shared store, so any failure to read them
    (truncated, garbage, crafted) is the same answer to the caller.
    """
    if len(data) < _HEADER.size:
        raise SnapshotError(f"not a session snapshot: {len(data)} bytes, shorter than its header")
    magic, version = _HEADER.unpack_from(data)
    if magic != MAGIC:
        raise SnapshotError(f"not a session snapshot: it starts with {magic!r}, not {MAGIC!r}")
    if version != FORMAT_VERSION:
        raise SnapshotError(
            f"snapshot format version {version} cannot be read: this build reads version {FORMAT_VERSION}"
        )
    try:
        inflate = zlib.decompressobj()
        raw = inflate.decompress(data[_HEADER.size :], MAX_BODY_BYTES)
        if inflate.unconsumed_tail:
            raise SnapshotError(f"snapshot body is larger than {MAX_BODY_BYTES} bytes")
        if not inflate.eof:
            raise SnapshotError("snapshot body is truncated")
        body = msgpack.unpackb(raw, raw=False, strict_map_key=True, unicode_errors="surrogatepass")
        return _Decoder(body, resolve).root()
    except SnapshotError:
        raise
    except Exception as error:  # any other failure on untrusted bytes: the caller gets one kind of error
        raise SnapshotError(f"corrupt session snapshot ({type(error).__name__}: {error})") from error


def _class_name(cls: type) -> str:
    return f"{cls.__module__}.{cls.__qualname__}"


def _pack(root: object, named: Mapping[int, Name]) -> bytes:
    encoder = _Encoder(named)
    node = encoder.node(root)
    return msgpack.packb([encoder.class_names, node], unicode_errors="surrogatepass")


_NATIVE = frozenset({type(None), bool, float, str, bytes})


class _Encoder:
    """One graph to nodes (module docstring); ``_memo`` numbers the objects met, as the decoder will."""

    def __init__(self, named: Mapping[int, Name]) -> None:
        self._named = named
        self._memo: dict[int, int] = {}  # id() -> number; every object in it stays alive until the end
        self._alive: list[object] = []  # objects made while encoding (a generator's state), kept so their
        # id() is not reused by another while the memo holds it
        self._class_numbers: dict[type, int] = {}
        self.class_names: list[str] = []
        self._allowed = allowed_classes()

    def node(self, value: Any) -> Any:
        kind = type(value)
        if kind in _NATIVE:
            return value
        if kind is int:
            return value if _INT_MIN <= value <= _INT_MAX else [Tag.BIGINT, str(value)]
        if kind is tuple:
            return [Tag.TUPLE, *[self.node(item) for item in value]]
        if kind is frozenset:
            return [Tag.FROZENSET, *[self.node(item) for item in value]]
        number = self._memo.get(id(value))
        if number is not None:
            return [Tag.REF, number]
        name = self._named.get(id(value))
        if name is not None:
            return self._name(value, name)
        if isinstance(value, enum.Enum):
            return [Tag.ENUM, self._class_number(kind), self.node(value.value)]
        if isinstance(value, datetime):
            return [Tag.DATETIME, value.isoformat()]
        if isinstance(value, PurePath):
            return [Tag.PATH, str(value)]
        if isinstance(value, np.generic):
            return [Tag.SCALAR, _dtype_text(value.dtype), value.tobytes()]
        self._memo[id(value)] = len(self._memo)  # before the contents: they may refer back to it
        if kind is list:
            return [Tag.LIST, *[self.node(item) for item in value]]
        if kind is dict:
            if all(type(key) is str for key in value):
                return {key: self.node(item) for key, item in value.items()}
            return [Tag.DICT, *[self.node(part) for pair in value.items() for part in pair]]
        if kind is set:
            return [Tag.SET, *[self.node(item) for item in value]]
        if kind is deque:
            return [Tag.DEQUE, value.maxlen, *[self.node(item) for item in value]]
        if kind is np.ndarray:
            return [Tag.ARRAY, _dtype_text(value.dtype), list(value.shape), value.tobytes()]
        if kind is np.random.Generator:
            bits_name = type(value.bit_generator).__name__
            if bits_name not in _BIT_GENERATORS:
                raise SnapshotError(f"cannot snapshot a random generator driven by {bits_name}")
            state = value.bit_generator.state  # a new dict at each access
            self._alive.append(state)
            return [Tag.GENERATOR, bits_name, self.node(state)]
        if kind is SemanticMap:
            return [Tag.SEMANTIC_MAP, value.to_bytes()]
        return self._instance(value)

    def _name(self, value: object, name: Name) -> Any:
        self._memo[id(value)] = len(self._memo)
        return [Tag.NAMED, *name]

    def _instance(self, value: object) -> Any:
        kind = type(value)
        number = self._class_number(kind)
        detached = _DETACHED.get(kind, {})
        attributes: dict[str, Any] = {}
        try:
            for key, item in vars(value).items():
                if key in detached and id(item) not in self._memo:
                    attributes[key] = self._name(item, detached[key](value))
                else:
                    attributes[key] = self.node(item)
        except SnapshotError as error:
            error.add_note(f"in a {kind.__qualname__}")
            raise
        return [Tag.OBJECT, number, attributes]

    def _class_number(self, kind: type) -> int:
        number = self._class_numbers.get(kind)
        if number is None:
            if self._allowed.get(_class_name(kind)) is not kind:
                raise SnapshotError(
                    f"cannot snapshot a {_class_name(kind)}: not in agent.snapshot.allowed_classes()"
                )
            number = self._class_numbers[kind] = len(self.class_names)
            self.class_names.append(_class_name(kind))
        return number


def _dtype_text(dtype: np.dtype[Any]) -> str:
    if dtype.kind not in _ARRAY_KINDS:
        raise SnapshotError(f"cannot snapshot numpy dtype {dtype} (only bool, integer, float, complex)")
    return dtype.str


def _dtype_of(text: object) -> np.dtype[Any]:
    if type(text) is not str:
        raise SnapshotError(f"a numpy dtype is named by text, got {type(text).__name__}")
    dtype = np.dtype(text)
    if dtype.kind not in _ARRAY_KINDS:
        raise SnapshotError(f"snapshot holds numpy dtype {dtype}, which it may not")
    return dtype


_PENDING = object()
"""Memo slot of an object numbered but not built yet (a REF to it is a cycle through an immutable)."""


class _Decoder:
    """Nodes back to objects, numbering them in the encoder's order."""

    def __init__(self, body: object, resolve: Callable[[Name], object]) -> None:
        if type(body) is not list or len(body) != 2 or type(body[0]) is not list:
            raise SnapshotError("snapshot body is not [class names, root]")
        names, self._root = body
        allowed = allowed_classes()
        unknown = [name for name in names if type(name) is not str or name not in allowed]
        if unknown:
            raise SnapshotError(f"snapshot names classes it may not hold: {unknown!r}")
        self._classes: list[type] = [allowed[name] for name in names]
        self._resolve = resolve
        self._memo: list[object] = []
        self._tags: dict[int, Callable[[list[Any]], object]] = {
            Tag.REF: self._ref,
            Tag.LIST: self._list,
            Tag.TUPLE: lambda node: tuple([self.node(item) for item in node[1:]]),
            Tag.SET: self._set,
            Tag.FROZENSET: lambda node: frozenset([self.node(item) for item in node[1:]]),
            Tag.DICT: self._pairs,
            Tag.DEQUE: self._deque,
            Tag.DATETIME: lambda node: datetime.fromisoformat(node[1]),
            Tag.PATH: lambda node: Path(node[1]),
            Tag.ENUM: self._enum,
            Tag.ARRAY: self._array,
            Tag.SCALAR: self._scalar,
            Tag.GENERATOR: self._generator,
            Tag.OBJECT: self._instance,
            Tag.NAMED: self._named,
            Tag.SEMANTIC_MAP: self._semantic_map,
            Tag.BIGINT: lambda node: int(node[1]),
        }

    def root(self) -> object:
        return self.node(self._root)

    def node(self, node: Any) -> object:
        kind = type(node)
        if kind is list:
            build = self._tags.get(node[0]) if node else None
            if build is None:
                raise SnapshotError(f"snapshot holds a node of unknown kind {node[:1]!r}")
            return build(node)
        if kind is dict:
            value: dict[str, object] = {}
            self._memo.append(value)
            for key, item in node.items():
                value[key] = self.node(item)
            return value
        return node

    def _number(self, value: object) -> int:
        self._memo.append(value)
        return len(self._memo) - 1

    def _ref(self, node: list[Any]) -> object:
        value = self._memo[node[1]] if type(node[1]) is int and 0 <= node[1] < len(self._memo) else _PENDING
        if value is _PENDING:
            raise SnapshotError(f"snapshot refers to object {node[1]!r}, which is not built before it")
        return value

    def _list(self, node: list[Any]) -> object:
        value: list[object] = []
        self._memo.append(value)
        value.extend([self.node(item) for item in node[1:]])
        return value

    def _set(self, node: list[Any]) -> object:
        value: set[object] = set()
        self._memo.append(value)
        value.update([self.node(item) for item in node[1:]])
        return value

    def _pairs(self, node: list[Any]) -> object:
        value: dict[object, object] = {}
        self._memo.append(value)
        items = [self.node(item) for item in node[1:]]
        if len(items) % 2:
            raise SnapshotError("snapshot holds a dict with a key and no value")
        value.update(zip(items[::2], items[1::2], strict=True))
        return value

    def _deque(self, node: list[Any]) -> object:
        value: deque[object] = deque(maxlen=node[1])
        self._memo.append(value)
        value.extend([self.node(item) for item in node[2:]])
        return value

    def _class(self, number: object) -> type:
        if type(number) is not int or not 0 <= number < len(self._classes):
            raise SnapshotError(f"snapshot refers to class {number!r} of {len(self._classes)}")
        return self._classes[number]

    def _enum(self, node: list[Any]) -> object:
        cls = self._class(node[1])
        if not issubclass(cls, enum.Enum):
            raise SnapshotError(f"snapshot holds {cls.__qualname__} as an enum member")
        return cls(self.node(node[2]))

    def _array(self, node: list[Any]) -> object:
        _, text, shape, data = node
        dtype = _dtype_of(text)
        if type(shape) is not list or not all(type(n) is int and n >= 0 for n in shape):
            raise SnapshotError(f"snapshot holds an array of shape {shape!r}")
        if type(data) is not bytes or len(data) != dtype.itemsize * int(np.prod(shape, dtype=object)):
            raise SnapshotError(f"snapshot holds an array whose bytes do not fill {dtype} {shape}")
        value = np.frombuffer(data, dtype=dtype).reshape(shape).copy()  # copy: writable, as it was
        self._number(value)
        return value

    def _scalar(self, node: list[Any]) -> object:
        _, text, data = node
        dtype = _dtype_of(text)
        if type(data) is not bytes or len(data) != dtype.itemsize:
            raise SnapshotError(f"snapshot holds a {dtype} scalar of {len(data)} bytes")
        return np.frombuffer(data, dtype=dtype)[0]

    def _generator(self, node: list[Any]) -> object:
        number = self._number(_PENDING)
        _, name, state = node
        bits_type = _BIT_GENERATORS.get(name) if type(name) is str else None
        if bits_type is None:
            raise SnapshotError(f"snapshot holds a random generator driven by {name!r}")
        state = self.node(state)
        if type(state) is not dict:
            raise SnapshotError(f"snapshot holds a {name} state that is not a dict")
        bits = bits_type()
        bits.state = state
        self._memo[number] = value = np.random.Generator(bits)
        return value

    def _instance(self, node: list[Any]) -> object:
        _, number, attributes = node
        cls = self._class(number)
        if issubclass(cls, enum.Enum) or type(attributes) is not dict:
            raise SnapshotError(f"snapshot holds a malformed {cls.__qualname__}")
        value = object.__new__(cls)  # no __init__: a constructor may load models or check its inputs
        self._memo.append(value)
        fields = value.__dict__
        for key, item in attributes.items():
            if type(key) is not str:
                raise SnapshotError(f"snapshot names an attribute of {cls.__qualname__} by {key!r}")
            fields[key] = self.node(item)
        return value

    def _named(self, node: list[Any]) -> object:
        name = tuple(node[1:])
        if not all(type(part) is str for part in name):
            raise SnapshotError(f"snapshot holds a malformed name {name!r}")
        value = self._resolve(name)
        self._memo.append(value)
        return value

    def _semantic_map(self, node: list[Any]) -> object:
        classes = self._resolve(("classes",))
        value = SemanticMap.from_bytes(node[1], classes)  # type: ignore[arg-type]
        self._memo.append(value)
        return value
