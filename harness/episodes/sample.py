"""A world and a TEACh task it can pose, drawn deterministically from a seed.

Task parameters come first (from the task's parameter space), then a room kind that can hold what they
name, then a world generated to contain it. Clean All X needs something dirty: when the generated world
happens to hold only clean X, some of them are made dirty, as TEACh's task set-ups do before a game.
"""

from __future__ import annotations

import random
from dataclasses import dataclass

from harness.tasks.sampling import is_feasible, parameter_space, required_types
from harness.tasks.teach import BENCHMARK_TASKS, TaskInstance, make_task_instance
from harness.world.model import RoomKind, World
from harness.world.procedural.config import WorldGenConfig, WorldGenError
from harness.world.procedural.generate import generate_world
from symbolic.ontology import load_ontology

KIND_PREFERENCE: dict[str, tuple[RoomKind, ...]] = {
    "Put All X On Y": ("living_room", "bedroom", "kitchen", "bathroom"),
    "Put All X In One Y": ("living_room", "bedroom", "kitchen", "bathroom"),
    "Clean All X": ("kitchen", "bathroom"),
}
"""Rooms tried for a task, in order; tasks not listed happen in kitchens (TEACh's cooking tasks)."""

MAX_TRIES = 60


class TaskSamplingError(RuntimeError):
    """No feasible (world, task) pair was found for a seed; the message says what was tried."""


@dataclass(frozen=True)
class TaskWorld:
    world: World
    task: TaskInstance
    world_seed: int
    task_seed: int


def sample_task_world(task_name: str, world_seed: int, task_seed: int) -> TaskWorld:
    """A feasible (world, task) for ``task_name``; deterministic in the two seeds."""
    if task_name not in BENCHMARK_TASKS:
        raise ValueError(f"unknown task {task_name!r}; known: {', '.join(BENCHMARK_TASKS)}")
    rng = random.Random(f"{task_name}|{task_seed}")
    space = parameter_space(task_name)
    kinds = KIND_PREFERENCE.get(task_name, ("kitchen",))
    problems: list[str] = []
    for attempt in range(MAX_TRIES):
        params = rng.choice(space) if space else ()
        task = make_task_instance(task_name, params)
        require = tuple(sorted(required_types(task).items()))
        for kind in kinds:
            config = WorldGenConfig(kind=kind, seed=world_seed + attempt * 7_777_777, require=require)
            try:
                world = generate_world(config)
            except (ValueError, WorldGenError) as error:
                problems.append(f"{kind} {params}: {error}"[:160])
                continue
            if task_name == "Clean All X":
                _dirty_some(world, task, rng)
            if is_feasible(task, world):
                return TaskWorld(world=world, task=task, world_seed=config.seed, task_seed=task_seed)
            problems.append(f"{kind} {params}: not feasible in the generated world")
    raise TaskSamplingError(
        f"no feasible world for {task_name!r} (seeds {world_seed}, {task_seed}): " + "; ".join(problems[-3:])
    )


def _dirty_some(world: World, task: TaskInstance, rng: random.Random) -> None:
    """Make at least one object of the task's class dirty (Clean All X is trivial otherwise)."""
    ontology = load_ontology()
    target = task.params[0]
    candidates = [
        o
        for o in world.objects.values()
        if ontology.has_class(o.object_type, target) and ontology.get(o.object_type).dirtyable
    ]
    if candidates and not any(o.is_dirty for o in candidates):
        for obj in rng.sample(candidates, k=max(1, len(candidates) // 2)):
            obj.is_dirty = True
