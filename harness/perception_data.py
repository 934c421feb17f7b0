"""Render training data for the learned perception networks and the goal transformer onto disk.

``models`` never imports the harness (DESIGN.md §2), so the harness writes files in the layouts the model
code reads (documented in ``models/perception/dataset.py`` and ``models/goal_transformer/dataset.py``):

- ``frames``: RGB, depth and instance segmentation from poses an agent actually takes (reachable cells,
  TEACh's four yaws, horizons -30..60 in 30° steps) in worlds whose openables, toggleables and sliceables
  are put in random states, so open fridges, slices and lit stoves appear as they do mid-task. Train worlds
  for ``--split train``, unseen worlds for ``valid_unseen`` (``harness.world.splits``), so "unseen" holds.
- ``search``: the search phases the goal transformer imitates (JARVIS §3, "GT predicts the next action"
  when the target is not in the map): from a pose where the target is not in view, the shortest sequence
  of TEACh's six body motions to a pose where it is (breadth-first over cells × yaws, the expert's
  knowledge of the world standing in for the human driver), with the frame seen before every action.

Usage: ``python -m harness.perception_data frames --out-dir DIR --split train --worlds 400``;
``python -m harness.perception_data search --out-dir DIR --split train --episodes 400``.
"""

from __future__ import annotations

import argparse
import json
import math
import random
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from harness.render.camera import CameraSpec
from harness.render.renderer import Frame, Renderer
from harness.sim import physics
from harness.sim.navgrid import reachable_grid
from harness.tasks.sampling import parameter_space, task_needs
from harness.tasks.teach_definitions import BENCHMARK_TASKS, make_task_instance
from harness.world.model import RoomKind, World, WorldObject
from harness.world.procedural.config import WorldGenConfig, WorldGenError
from harness.world.procedural.generate import generate_world
from harness.world.splits import Split, world_seed
from symbolic.cli_args import Parser, int_at_least, plain, positive_float
from symbolic.ontology import Ontology, load_ontology
from symbolic.thor import CAMERA_HEIGHT_M, GRID_STEP_M, TEACH_HFOV_DEG

ROOM_KINDS: tuple[RoomKind, ...] = ("kitchen", "living_room", "bedroom", "bathroom")
HORIZONS_DEG: tuple[int, ...] = (-30, 0, 30, 60)
HORIZON_WEIGHTS: tuple[float, ...] = (0.1, 0.35, 0.4, 0.15)
"""TEACh drivers mostly look level or 30° down; up and far down are rarer but must be seen in training."""
MOTION_EFFECTS: dict[str, tuple[int, int]] = {
    "Forward": (0, 0),
    "Backward": (2, 0),
    "Pan Left": (3, 0),
    "Pan Right": (1, 0),
    "Turn Left": (-1, -1),
    "Turn Right": (-1, 1),
}
"""The goal transformer's action space (JARVIS appendix: the six body motions). Moves: (quarter turns from
the body's heading to the step direction, 0); turns: (-1, change of heading in quarter turns)."""
EXPERT_ACTIONS: tuple[str, ...] = ("Forward", "Turn Left", "Turn Right")
"""What the search expert uses: a person driving looks and walks ahead; blind backward and sideways steps,
though never longer, would teach the goal transformer to walk where it cannot see."""


@dataclass(frozen=True)
class StateRandomization:
    """Chances that an object starts in a non-default state, so mid-task looks are in the training data."""

    open_prob: float = 0.4  # openables (fridge, cabinets, drawers, microwave) shown open
    toggle_prob: float = 0.3  # toggleables shown on
    slice_prob: float = 0.3  # sliceables replaced by their slices


@dataclass(frozen=True)
class SearchConfig:
    """Search-phase episodes: what counts as seeing the target, and how long a search may be."""

    visible_min_pixels: int = (
        12  # target pixels at the visibility check's resolution that count as a sighting
    )
    check_side_px: int = 96  # side of the geometry-only frames used for the visibility check (pixels)
    min_steps: int = 2  # shorter searches teach little (the target is almost in view)
    max_steps: int = 40  # longer ones are rare and mostly walk around furniture


def task_classes(ontology: Ontology) -> list[str]:
    """Every object type a TEACh benchmark task may name (all interchangeable options of every need)."""
    names: set[str] = set()
    for task in BENCHMARK_TASKS:
        for params in parameter_space(task):
            for options in task_needs(make_task_instance(task, params), ontology=ontology):
                names.update(options)
    return sorted(names)


def randomize_states(
    world: World, rng: random.Random, config: StateRandomization, ontology: Ontology
) -> None:
    """Open, switch on and slice objects at random (in place), as they look partway through tasks."""
    for obj in list(world.objects.values()):
        info = ontology.get(obj.object_type)
        if info.openable and rng.random() < config.open_prob:
            obj.is_open = True
        if info.toggleable and rng.random() < config.toggle_prob:
            physics.set_toggled(world, obj, True)
        if info.sliceable and info.sliced_into and rng.random() < config.slice_prob:
            try:
                physics.slice_object(world, obj, ontology)
            except KeyError:  # the harness has no slice count for this type: leave it whole
                continue
    physics.apply_rules(world, ontology)


def _world(split: Split, index: int) -> World | None:
    kind = ROOM_KINDS[index % len(ROOM_KINDS)]
    try:
        return generate_world(WorldGenConfig(kind, world_seed(split, index)))
    except WorldGenError:
        return None


def _place_agent(world: World, cell: tuple[int, int], yaw: int, horizon: float) -> None:
    world.agent.x, world.agent.z = world.room.cell_center(*cell)
    world.agent.yaw, world.agent.horizon = yaw, horizon


def write_frame(out: Path, name: str, frame: Frame) -> None:
    """One frame in the perception layout: rgb PNG, 16-bit millimetre depth PNG, 16-bit ids PNG + legend."""
    assert frame.rgb is not None, "frames for training need RGB"
    cv2.imwrite(str(out / "rgb" / f"{name}.png"), cv2.cvtColor(frame.rgb, cv2.COLOR_RGB2BGR))
    depth_mm = np.clip(np.round(frame.depth * 1000.0), 0, 65535).astype(np.uint16)
    cv2.imwrite(str(out / "depth" / f"{name}.png"), depth_mm)
    assert int(frame.instances.max(initial=0)) < 65536, "instance ids must fit a 16-bit PNG"
    cv2.imwrite(str(out / "instances" / f"{name}.png"), frame.instances.astype(np.uint16))
    legend = {str(k): v for k, v in sorted(frame.legend.items())}
    (out / "instances" / f"{name}.json").write_text(json.dumps(legend))


FOCUS_DISTANCE_M = (0.5, 1.5)
"""Range of floor distances from an object at which a focused frame is taken (an agent about to handle it)."""


def focused_pose(
    world: World, cells: Sequence[tuple[int, int]], rng: random.Random, ontology: Ontology
) -> tuple[tuple[int, int], int, float] | None:
    """A pose looking at a random small object from near, as an agent sees what it is about to pick up or
    put something on: one object type drawn uniformly (so rare types are as common as mugs), one instance,
    a reachable cell 0.5-1.5 m away, the yaw of the four nearest its direction and the look step nearest
    its elevation. None when the world has no small object with such a cell."""
    obj = _random_pickupable(world, rng, ontology, resting_only=True)
    if obj is None:
        return None
    x, y, z = obj.center
    near = []
    for cell in cells:
        cx, cz = world.room.cell_center(*cell)
        if FOCUS_DISTANCE_M[0] <= math.hypot(x - cx, z - cz) <= FOCUS_DISTANCE_M[1]:
            near.append(cell)
    if not near:
        return None
    cell = rng.choice(near)
    cx, cz = world.room.cell_center(*cell)
    bearing = math.degrees(math.atan2(x - cx, z - cz))  # yaw 0 faces +z, 90 faces +x
    yaw = int(round(bearing / 90.0)) % 4 * 90
    below = math.degrees(math.atan2(CAMERA_HEIGHT_M - y, math.hypot(x - cx, z - cz)))  # positive: look down
    horizon = min(HORIZONS_DEG, key=lambda h: abs(h - below))
    return cell, yaw, float(horizon)


def hold_random_object(world: World, rng: random.Random, ontology: Ontology) -> WorldObject | None:
    """Put a random pickupable object in the agent's hand (one type drawn uniformly, then one instance):
    the renderer draws it in front of the camera, as AI2-THOR shows what the agent carries. None when the
    world has nothing pickupable. The caller empties the hand (``world.agent.held = None``) afterwards."""
    obj = _random_pickupable(world, rng, ontology, resting_only=False)
    if obj is not None:
        world.agent.held = obj.object_id
    return obj


def _random_pickupable(
    world: World, rng: random.Random, ontology: Ontology, *, resting_only: bool
) -> WorldObject | None:
    """One pickupable object: a type drawn uniformly (so rare types are as common as mugs), then one of
    its instances; ``resting_only`` keeps to objects lying on or in something. None if there is none."""
    by_type: dict[str, list[WorldObject]] = {}
    for obj in world.objects.values():
        if ontology.get(obj.object_type).pickupable and (obj.parent_id is not None or not resting_only):
            by_type.setdefault(obj.object_type, []).append(obj)
    if not by_type:
        return None
    return rng.choice(by_type[rng.choice(sorted(by_type))])


def render_frames(
    out: Path,
    split: Split,
    worlds: int,
    per_world: int,
    camera: CameraSpec,
    seed: int,
    randomization: StateRandomization = StateRandomization(),
    focus_share: float = 0.0,
    held_share: float = 0.0,
) -> int:
    """Write ``per_world`` frames from each of ``worlds`` worlds of ``split``; returns frames written.

    Frames are taken from random reachable poses, or with probability ``focus_share`` looking at a small
    object from near (``focused_pose``): uniform poses mostly show walls and floor, and a network trained
    on them sees a salt shaker a few dozen pixels at a time. With probability ``held_share`` the agent also
    holds a random object (``hold_random_object``): an agent carries something for half of a task, and
    networks that never saw a held object read it as a far table (wrong depth, wrong class) and the
    executor then clicks on it."""
    ontology = load_ontology()
    for folder in ("rgb", "depth", "instances"):
        (out / folder).mkdir(parents=True, exist_ok=True)
    renderer = Renderer(camera)
    rng = random.Random(f"frames/{split}/{seed}")
    written = 0
    for index in tqdm(range(worlds), desc=f"frames {split}", unit="world"):
        world = _world(split, index)
        if world is None:
            continue
        randomize_states(world, rng, randomization, ontology)
        cells = [(int(r), int(c)) for r, c in np.argwhere(reachable_grid(world))]
        for k in range(per_world):
            focused = focused_pose(world, cells, rng, ontology) if rng.random() < focus_share else None
            if focused is not None:
                _place_agent(world, *focused)
            else:
                cell = rng.choice(cells)
                horizon = rng.choices(HORIZONS_DEG, HORIZON_WEIGHTS)[0]
                _place_agent(world, cell, 90 * rng.randrange(4), float(horizon))
            if rng.random() < held_share:
                hold_random_object(world, rng, ontology)
            frame = renderer.render(world, noise_seed=rng.randrange(1 << 30))
            world.agent.held = None
            write_frame(out, f"{split}_w{index:05d}_f{k:02d}", frame)
            written += 1
    meta = {
        "source": "harness.perception_data frames",
        "split": split,
        "camera": {"width": camera.width, "height": camera.height, "hfov_deg": camera.hfov_deg},
        "task_classes": task_classes(ontology),
        "frames": written,
        "seed": seed,
        "focus_share": focus_share,
        "held_share": held_share,
    }
    (out / "meta.json").write_text(json.dumps(meta, indent=1))
    return written


# ------------------------------------------------------------------------------------------ search phases

State = tuple[int, int, int]
"""(cell x index, cell z index, heading 0..3 with heading h facing yaw 90·h)."""
_STEP_OF_HEADING: tuple[tuple[int, int], ...] = ((0, 1), (1, 0), (0, -1), (-1, 0))


def successor(state: State, action: str, free: np.ndarray) -> State | None:
    """Where a search action leads on the reachable grid, None when blocked (AI2-THOR's failed move)."""
    i, j, heading = state
    quarter, turn = MOTION_EFFECTS[action]
    if quarter < 0:
        return i, j, (heading + turn) % 4
    di, dj = _STEP_OF_HEADING[(heading + quarter) % 4]
    ni, nj = i + di, j + dj
    NX, NZ = free.shape
    if 0 <= ni < NX and 0 <= nj < NZ and free[ni, nj]:
        return ni, nj, heading
    return None


def shortest_search(
    start: State, is_goal: Callable[[State], bool], free: np.ndarray, max_steps: int
) -> list[str] | None:
    """Breadth-first: the fewest search actions from ``start`` to a state where ``is_goal`` holds (None past
    ``max_steps``); ``is_goal`` is asked lazily, in order of distance, so few states are ever rendered."""
    parents: dict[State, tuple[State, str] | None] = {start: None}
    queue: deque[tuple[State, int]] = deque([(start, 0)])
    while queue:
        state, depth = queue.popleft()
        if is_goal(state):
            actions: list[str] = []
            link = parents[state]
            while link is not None:
                state, action = link
                actions.append(action)
                link = parents[state]
            return actions[::-1]
        if depth == max_steps:
            continue
        for action in EXPERT_ACTIONS:
            nxt = successor(state, action, free)
            if nxt is not None and nxt not in parents:
                parents[nxt] = (state, action)
                queue.append((nxt, depth + 1))
    return None


class SightingCheck:
    """Whether the target is in view from a state at a fixed horizon (geometry-only renders, memoised)."""

    def __init__(self, world: World, target_ids: set[int], horizon: float, config: SearchConfig) -> None:
        self._world = world
        self._ids = np.fromiter(target_ids, dtype=np.int64)
        self._horizon = horizon
        self._min_pixels = config.visible_min_pixels
        self._renderer = Renderer(CameraSpec(config.check_side_px, config.check_side_px, TEACH_HFOV_DEG))
        self._seen: dict[State, bool] = {}

    def __call__(self, state: State) -> bool:
        if state not in self._seen:
            _place_agent(self._world, state[:2], 90 * state[2], self._horizon)
            instances = self._renderer.render(self._world, want_rgb=False).instances
            self._seen[state] = int(np.isin(instances, self._ids).sum()) >= self._min_pixels
        return self._seen[state]


def _interaction_after_navigate(object_type: str, ontology: Ontology) -> str | None:
    """The subgoal that usually follows reaching an object (JARVIS's future subgoals): what it affords."""
    info = ontology.get(object_type)
    for action, afforded in (
        ("Pickup", info.pickupable),
        ("Open", info.openable),
        ("ToggleOn", info.toggleable),
    ):
        if afforded:
            return action
    return None


def search_episodes(
    split: Split, episodes: int, seed: int, config: SearchConfig = SearchConfig()
) -> Iterator[tuple[World, dict[str, object], list[str]]]:
    """Search-phase episodes: (world at the start pose, record, expert actions); deterministic in ``seed``."""
    ontology = load_ontology()
    wanted = set(task_classes(ontology))
    rng = random.Random(f"search/{split}/{seed}")
    made, index = 0, 0
    while made < episodes:
        index += 1
        world = _world(split, index)
        if world is None:
            continue
        randomize_states(world, rng, StateRandomization(slice_prob=0.0), ontology)
        types = sorted({o.object_type for o in world.objects.values()} & wanted)
        if not types:
            continue
        target = rng.choice(types)
        target_ids = {world.instance_ids[o.object_id] for o in world.of_type(target)}
        free = reachable_grid(world)
        horizon = float(rng.choice((0, 30)))
        sighted = SightingCheck(world, target_ids, horizon, config)
        cells = np.argwhere(free)
        row, col = cells[rng.randrange(len(cells))]
        start = (int(row), int(col), rng.randrange(4))
        actions = shortest_search(start, sighted, free, config.max_steps)
        if actions is None or len(actions) < config.min_steps:
            continue
        _place_agent(world, start[:2], 90 * start[2], horizon)
        subgoals = [["Navigate", target]]
        follow = _interaction_after_navigate(target, ontology)
        if follow is not None:
            subgoals.append([follow, target])
        record: dict[str, object] = {
            "world_seed": world.seed,
            "room_kind": world.room.kind,
            "target": target,
            "subgoals": subgoals,
            "start": {"x": world.agent.x, "z": world.agent.z, "yaw": world.agent.yaw, "horizon": horizon},
            "actions": actions,
            "grid_step_m": GRID_STEP_M,
        }
        made += 1
        yield world, record, actions


def render_search(out: Path, split: Split, episodes: int, camera: CameraSpec, seed: int) -> int:
    """Write each search episode as ``NAME/frames/TTT.png`` (the frame before action T) + ``episode.json``."""
    renderer = Renderer(camera)
    rng = random.Random(f"search-noise/{split}/{seed}")
    written = 0
    progress = tqdm(total=episodes, desc=f"search {split}", unit="episode")
    for n, (world, record, actions) in enumerate(search_episodes(split, episodes, seed)):
        folder = out / f"{split}_e{n:05d}"
        (folder / "frames").mkdir(parents=True, exist_ok=True)
        free = reachable_grid(world)
        cell = world.room.cell_of(world.agent.x, world.agent.z)
        state: State = (cell[0], cell[1], (world.agent.yaw // 90) % 4)
        for t, action in enumerate(actions):
            _place_agent(world, state[:2], 90 * state[2], world.agent.horizon)
            frame = renderer.render(world, noise_seed=rng.randrange(1 << 30))
            assert frame.rgb is not None
            cv2.imwrite(str(folder / "frames" / f"{t:03d}.png"), cv2.cvtColor(frame.rgb, cv2.COLOR_RGB2BGR))
            nxt = successor(state, action, free)
            assert nxt is not None, f"expert action {action} from {state} is blocked"
            state = nxt
        (folder / "episode.json").write_text(json.dumps(record, indent=1))
        written += 1
        progress.update()
    progress.close()
    meta = {
        "source": "harness.perception_data search",
        "split": split,
        "camera": {"width": camera.width, "height": camera.height, "hfov_deg": camera.hfov_deg},
        "episodes": written,
        "seed": seed,
    }
    (out / "meta.json").write_text(json.dumps(meta, indent=1))
    return written


def _parser() -> argparse.ArgumentParser:
    parser = Parser(prog="python -m harness.perception_data", description=plain(__doc__.split("\n")[0]))
    sub = parser.add_subparsers(dest="command", required=True)
    for name, help_ in (("frames", "RGB/depth/segmentation frames"), ("search", "search-phase trajectories")):
        p = sub.add_parser(name, help=help_)
        p.add_argument("--out-dir", type=Path, required=True, help="folder to write (created)")
        p.add_argument("--split", choices=("train", "valid_unseen"), default="train")
        p.add_argument("--seed", type=int, default=0)
        p.add_argument(
            "--size",
            type=int_at_least(32),
            default=256 if name == "frames" else 224,
            help="image side, pixels",
        )
        p.add_argument(
            "--hfov", type=positive_float, default=TEACH_HFOV_DEG, help="horizontal field of view, degrees"
        )
    frames = sub.choices["frames"]
    frames.add_argument("--worlds", type=int_at_least(1), default=400, help="worlds generated")
    frames.add_argument("--per-world", type=int_at_least(1), default=12, help="frames per world")
    frames.add_argument(
        "--focus-share", type=float, default=0.0, help="share of frames looking at a small object from near"
    )
    frames.add_argument(
        "--held-share", type=float, default=0.0, help="share of frames with a random object in the hand"
    )
    search = sub.choices["search"]
    search.add_argument("--episodes", type=int_at_least(1), default=400, help="episodes to render")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    camera = CameraSpec(args.size, args.size, args.hfov)
    if args.command == "frames":
        count = render_frames(
            args.out_dir,
            args.split,
            args.worlds,
            args.per_world,
            camera,
            args.seed,
            focus_share=args.focus_share,
            held_share=args.held_share,
        )
        tqdm.write(f"wrote {count} frames to {args.out_dir}")
    else:
        count = render_search(args.out_dir, args.split, args.episodes, camera, args.seed)
        tqdm.write(f"wrote {count} search episodes to {args.out_dir}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
