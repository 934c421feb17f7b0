"""What a reader sees of a session: an immutable view published after each completed change.

A step holds its session's lock (its lease in Redis) for the whole step, so a reader that took the lock too
(``GET /v1/sessions/{id}``, its trace and map, the live page) waited for it or was refused 409. Instead the
write path publishes a ``SessionView`` after every completed creation, step and utterance, built while it
still holds the session, and every read takes the latest view without the lock: it shows the state after
the last completed change and never waits on a step in progress.

Publishing must cost a step little (DESIGN.md §8: a 12 ms step): the view keeps the public JSON (0.05 ms),
the kept trace lines (references to immutable strings), a copy of the map's arrays rather than its picture
(0.1 ms; drawing the PNG takes ~6 ms, so it is drawn on first read and memoized), and the step's RGB frame
(encoded as a small JPEG when first read: 0.3-0.6 ms; the browser draws the click point over it). With
Redis the view also travels as bytes: the map in its compact snapshot form (``SemanticMap.to_bytes``, which
the session's snapshot made a moment before and the map keeps) and the frame encoded.
"""

from __future__ import annotations

import functools
import threading
from dataclasses import asdict, dataclass, field
from typing import Any

import cv2
import msgpack
import numpy as np
import orjson
import pybase64

from agent.geometry import Pose
from agent.mapping.picture import render_map_png
from agent.mapping.semantic_map import SemanticMap
from agent.session import AgentSession
from app.views import session_public

EVENT_TRACE_LINES = 20
"""Trace lines an event (and a view read back from Redis) carries: what the page shows."""
FRAME_MAX_SIDE = 480
"""Pixels: the published frame's longer side at most (a 900x900 TEACh frame is shrunk first; encoding it
whole took 3.5 ms)."""
FRAME_JPEG_QUALITY = 85
VIEW_FORMAT = 1
"""Version of ``SessionView.to_bytes``'s layout; a view of another version reads as absent."""


@dataclass(frozen=True, eq=False)
class LiveFrame:
    """The RGB frame a step answered, and where that answer clicks on it (fractions of width and height).

    A step keeps the decoded frame as it is and a reader encodes it (``jpeg``, once): most steps are never
    watched, and encoding took 0.3-0.8 ms of a step. Read back from Redis it arrives encoded."""

    step: int
    action: str
    x: float | None
    y: float | None
    rgb: np.ndarray | None = field(default=None, repr=False)  # uint8 [H, W, 3], never changed
    encoded: bytes | None = field(default=None, repr=False)

    @functools.cached_property
    def jpeg(self) -> bytes:
        if self.encoded is not None:
            return self.encoded
        assert self.rgb is not None, "a live frame holds its pixels or their JPEG"
        return encode_jpeg(self.rgb)


@dataclass(frozen=True)
class MapState:
    """What drawing the map needs: the view's own copy of the map and what the picture marks on it."""

    semantic_map: SemanticMap  # never changed after publishing, except its memoized 2D layers
    pose: Pose | None  # the agent, in the map's frame
    path: tuple[tuple[int, int], ...]
    target: str | None


@dataclass(frozen=True, eq=False)
class SessionView:
    """One session as readers see it after a completed change. ``revision`` (``"<steps>.<turns>"``: steps
    answered, dialogue turns) grows with every change, so it names the state an event showed."""

    session_id: str
    revision: str
    step: int
    public_json: bytes  # SessionPublic as JSON
    trace: tuple[str, ...]  # trace lines (JSON text), oldest first
    map_state: MapState | None  # None before the first step: ``empty_map_png`` is drawn instead
    empty_map_png: bytes | None
    frame: LiveFrame | None
    _drawn: dict[str, bytes] = field(default_factory=dict, repr=False)
    _draw_guard: threading.Lock = field(default_factory=threading.Lock, repr=False)

    # ----- what readers ask for ----------------------------------------------------------------------
    def map_png(self) -> bytes:
        """The semantic map picture of this state, drawn once per view (about 6 ms; call it off the event
        loop the first time)."""
        if self.map_state is None:
            assert self.empty_map_png is not None, "a view without a map state carries the empty map"
            return self.empty_map_png
        with self._draw_guard:
            if "map" not in self._drawn:
                state = self.map_state
                self._drawn["map"] = render_map_png(
                    state.semantic_map,
                    agent_pose=state.pose,
                    path_cells=state.path or None,
                    target_type=state.target,
                )
            return self._drawn["map"]

    @property
    def map_drawn(self) -> bool:
        return self.map_state is None or "map" in self._drawn

    def trace_lines(self, since: int | None = None) -> list[str]:
        """The kept trace lines, from step ``since`` on when given."""
        if since is None:
            return list(self.trace)
        return [line for line in self.trace if orjson.loads(line)["step"] >= since]

    def event(self) -> dict[str, Any]:
        """The live page's event: everything it shows of this state (images as base64 data)."""
        public = orjson.loads(self.public_json)
        tail = [orjson.loads(line) for line in self.trace[-EVENT_TRACE_LINES:]]
        return {
            "revision": self.revision,
            "step": self.step,
            "session": public,
            "progress": progress(public, tail),
            "trace": tail,
            "map_png": _base64(self.map_png()),
            "frame": None
            if self.frame is None
            else {
                "jpeg": _base64(self.frame.jpeg),
                "step": self.frame.step,
                "action": self.frame.action,
                "x": self.frame.x,
                "y": self.frame.y,
            },
        }

    # ----- Redis ---------------------------------------------------------------------------------------
    def to_bytes(self, trace_lines: int = EVENT_TRACE_LINES) -> bytes:
        """The view without its frame (stored apart: an utterance keeps the last step's frame) and with only
        the last ``trace_lines`` lines (the whole trace is kept per line, ``RedisSessionStore``)."""
        state = self.map_state
        return bytes(
            msgpack.packb(
                {
                    "v": VIEW_FORMAT,
                    "id": self.session_id,
                    "rev": self.revision,
                    "step": self.step,
                    "public": self.public_json,
                    "trace": list(self.trace[-trace_lines:]),
                    "map": None
                    if state is None
                    else [
                        state.semantic_map.to_bytes(),
                        asdict(state.pose) if state.pose is not None else None,
                        [list(cell) for cell in state.path],
                        state.target,
                    ],
                    "empty_map": self.empty_map_png,
                }
            )
        )

    @classmethod
    def from_bytes(cls, data: bytes, frame: bytes | None) -> SessionView | None:
        """The view ``to_bytes`` wrote and the frame stored beside it; None for another format's view."""
        fields = msgpack.unpackb(data)
        if not isinstance(fields, dict) or fields.get("v") != VIEW_FORMAT:
            return None
        raw_map = fields["map"]
        map_state = None
        if raw_map is not None:
            snapshot, pose, path, target = raw_map
            map_state = MapState(
                SemanticMap.from_bytes(snapshot),
                Pose(**pose) if pose is not None else None,
                tuple((int(i), int(j)) for i, j in path),
                target,
            )
        return cls(
            session_id=fields["id"],
            revision=fields["rev"],
            step=int(fields["step"]),
            public_json=fields["public"],
            trace=tuple(fields["trace"]),
            map_state=map_state,
            empty_map_png=fields["empty_map"],
            frame=frame_from_bytes(frame) if frame else None,
        )


def revision_of(session: AgentSession) -> str:
    """``"<steps answered>.<dialogue turns>"``: a step or an utterance changes it, a retried step does not."""
    return f"{session.step}.{len(session.dialogue)}"


def build_view(session: AgentSession, frame: LiveFrame | None) -> SessionView:
    """The view of ``session`` as it stands (call it while holding the session)."""
    semantic_map = session.semantic_map
    map_state = None
    empty = None
    if semantic_map is None:
        empty = session.map_png()  # no step yet: the empty map, drawn once at creation
    else:
        current = session.current_subgoal()
        map_state = MapState(
            semantic_map=semantic_map.copy(),
            pose=session.pose,
            path=tuple((int(i), int(j)) for i, j in session.last_path),
            target=session.last_target or (current.obj if current is not None else None),
        )
    return SessionView(
        session_id=session.session_id,
        revision=revision_of(session),
        step=session.step,
        public_json=session_public(session).model_dump_json().encode(),
        trace=tuple(session.trace.lines()),
        map_state=map_state,
        empty_map_png=empty,
        frame=frame,
    )


def step_frame(session: AgentSession, rgb: np.ndarray | None) -> LiveFrame | None:
    """The frame of the step ``session`` just answered, with that answer's click point; None without RGB."""
    decision = session.last_decision
    if rgb is None or decision is None:
        return None
    return LiveFrame(decision.step, decision.action, decision.x, decision.y, rgb=rgb)


def encode_jpeg(rgb: np.ndarray) -> bytes:
    """uint8 [H, W, 3] RGB as a JPEG whose longer side is at most ``FRAME_MAX_SIDE``."""
    H, W, _ = rgb.shape
    scale = FRAME_MAX_SIDE / max(H, W)
    if scale < 1.0:
        rgb = cv2.resize(
            rgb, (max(1, round(W * scale)), max(1, round(H * scale))), interpolation=cv2.INTER_AREA
        )
    ok, encoded = cv2.imencode(
        ".jpg", np.ascontiguousarray(rgb[:, :, ::-1]), [cv2.IMWRITE_JPEG_QUALITY, FRAME_JPEG_QUALITY]
    )
    if not ok:
        raise ValueError(f"rgb: OpenCV could not encode a {W}x{H} frame as JPEG")
    return bytes(encoded.tobytes())


def frame_to_bytes(frame: LiveFrame) -> bytes:
    return bytes(msgpack.packb([frame.jpeg, frame.step, frame.action, frame.x, frame.y]))


def frame_from_bytes(data: bytes) -> LiveFrame:
    jpeg, step, action, x, y = msgpack.unpackb(data)
    return LiveFrame(int(step), str(action), x, y, encoded=jpeg)


def progress(public: dict[str, Any], trace: list[dict[str, Any]]) -> dict[str, Any]:
    """What the service knows of the episode's progress. Success rate and goal conditions are not among it:
    no request carries them (the harness scores SR and GC against its world after the episode)."""
    plan = public["plan"]
    return {
        "subgoals_done": min(plan["pointer"], len(plan["subgoals"])),
        "subgoals": len(plan["subgoals"]),
        "steps": public["step"],
        "done": public["done"],
        "failed_actions_recent": sum(1 for entry in trace if entry.get("last_action_success") is False),
        "goal_conditions": None,
    }


def _base64(data: bytes) -> str:
    return pybase64.b64encode(data).decode("ascii")
