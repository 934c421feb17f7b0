"""Commander/follower dialogues for an expert trajectory, in the manner of TEACh's human games.

TEACh pairs a Commander, who sees the task and can search for objects, with a Driver (the follower) who
acts. Their chats follow a pattern this module reproduces with seeded variation:

1. ``plan_steps``: the expert's interactions become the things a commander would ask for ("slice the
   tomato", "toast a slice of bread", "rinse the mug", "put 2 slices on the plate"); moving, opening,
   closing, fetching a knife and putting it down afterwards are left for the follower to work out, as
   TEACh commanders leave them. Each step owns a contiguous range of driver actions.
2. ``chunk_steps``: the commander gives one or two steps per instruction.
3. ``write_dialogue``: greetings and the task ("Hi, today we're making a salad. First slice a tomato."),
   the follower asking what to do, asking where things are when they are out of sight (answered with a
   place computed from the world: "in the cabinet above the toaster", "on the counter left of the sink"),
   acknowledging, reporting ("I sliced the tomato", "what's next?"), small talk, and the commander
   closing ("great job, we're done"). The turns before each chunk's actions are where an EDH instance can
   be cut (TEACh cuts its EDH instances at dialogue turns, the future running to the next utterance).

Wording comes from ``phrases.json`` (``harness.episodes.phrases``); typing style and typos per speaker.
"""

from __future__ import annotations

import math
import random
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import Literal, Protocol

from harness.episodes.phrases import PhraseBank, Voice, draw_voice, template_slots, typed
from harness.render.renderer import Renderer
from harness.tasks.teach import TaskInstance
from harness.world.catalog import load_catalog
from harness.world.model import World, WorldObject
from symbolic.ontology import Ontology, UnknownObjectType
from symbolic.subgoals import object_type_of_id

StepKind = Literal[
    "slice",
    "put",
    "put_slices",
    "toast",
    "microwave",
    "coffee",
    "rinse",
    "fill",
    "water_plant",
    "empty",
    "pour",
    "turn_on",
    "turn_off",
    "pickup",
]
TeachSpeaker = Literal["Commander", "Driver"]

MERGEABLE: frozenset[str] = frozenset({"put_slices", "toast", "microwave"})
"""Repeated steps of these kinds on one device/receptacle are said once with a count ("toast 2 slices")."""
SWITCHED_DEVICES: dict[str, StepKind] = {
    "Toaster": "toast",
    "Microwave": "microwave",
    "CoffeeMachine": "coffee",
}
"""Receptacles where putting something in and switching on is one thing to a person ("toast the bread")."""
WASH_BASINS: frozenset[str] = frozenset({"SinkBasin", "Sink"})
"""Putting something here and running the faucet is rinsing (dirty) or filling (clean and fillable)."""
SPOKEN_AS: dict[str, str] = {"StoveKnob": "StoveBurner"}
"""Things people name by what they control ("turn on the stove", not "the stove knob")."""
STACKED_STORAGE: frozenset[str] = frozenset({"Cabinet", "Drawer", "Shelf"})
"""Holders people place above or below a landmark ("the cabinet above the toaster")."""
RELATION_MARGIN_M = 0.25
"""Sideways offset below which "next to" is said instead of left/right."""
LANDMARK_RANGE_M = 2.0
"""Farthest a landmark may be (horizontally) from the object to be used in a place reference."""
STACK_OVERLAP_M = 0.05
"""Footprints must overlap by this much for "above"/"below" to be said."""


class DriverAction(Protocol):
    """What dialogue planning needs of a driver action (the expert's ExpertAction has it)."""

    @property
    def action(self) -> str: ...
    @property
    def object_id(self) -> str | None: ...
    @property
    def success(self) -> bool: ...


@dataclass(frozen=True)
class Step:
    """One thing a commander asks for, over driver actions ``[start, end)``."""

    kind: StepKind
    start: int
    end: int
    obj: str | None = None
    """Type acted on (slice, turn_on, pickup ...)."""
    held: str | None = None
    """Type in hand that the step puts, rinses, fills, pours or toasts."""
    recep: str | None = None
    """Type it goes into or onto."""
    recep_id: str | None = None
    count: int = 1
    targets: tuple[str, ...] = ()
    """Object ids the follower has to find for this step, in the order it uses them."""


@dataclass(frozen=True)
class Chunk:
    """Steps given in one instruction; its driver actions are ``[start, end)``."""

    steps: tuple[Step, ...]

    @property
    def start(self) -> int:
        return self.steps[0].start

    @property
    def end(self) -> int:
        return self.steps[-1].end

    @property
    def targets(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys(t for step in self.steps for t in step.targets))


@dataclass(frozen=True)
class Turn:
    """One chat message: who, why (a TEACh dialogue-act-like intent), what was typed and its clean form."""

    speaker: TeachSpeaker
    intent: str
    utterance: str
    corrected: str
    about: str | None = None
    """For place answers: the object id asked about."""
    place_receptacle: str | None = None
    """For place answers: the receptacle id the answer names."""


@dataclass(frozen=True)
class Dialogue:
    """Turns before each chunk's actions (``before[i]``) and after the last chunk (``closing``)."""

    before: tuple[tuple[Turn, ...], ...]
    closing: tuple[Turn, ...]

    def turns(self) -> list[Turn]:
        return [turn for group in self.before for turn in group] + list(self.closing)


@dataclass(frozen=True)
class DialogueConfig:
    """How often each optional move happens (probabilities per opportunity)."""

    driver_opens: float = 0.55  # the follower speaks first ("hi, what should I do?")
    split_intro: float = 0.4  # the task and the first step come in two messages
    small_talk: float = 0.12  # "how are you?" at the start
    two_steps: float = 0.35  # an instruction carries two steps
    ack: float = 0.35  # the follower acknowledges an instruction
    ask_where: float = 0.6  # the follower asks where an out-of-sight object is
    volunteer_where: float = 0.35  # otherwise the commander says where it is unasked
    report: float = 0.7  # the follower reports a finished step
    ask_next: float = 0.4  # ...and asks for the next one
    feedback: float = 0.5  # the commander praises before the next instruction
    thanks: float = 0.6  # the follower thanks at the end
    typo_rate: float = 0.03  # per word of 4+ letters, scaled per speaker by draw_voice


# ---- steps from actions --------------------------------------------------------------------------


def _type(object_id: str) -> str:
    return object_type_of_id(object_id)


@dataclass
class _Pending:
    """Targets met since the last step (pickups, receptacles) that the next step will own."""

    targets: list[str] = field(default_factory=list)

    def add(self, object_id: str) -> None:
        if object_id not in self.targets:
            self.targets.append(object_id)


def _next_toggle(interactions: Sequence[tuple[int, str, str]], k: int, device_type: str) -> int | None:
    """Position in ``interactions`` of a ToggleOn of a device right after k (opening/closing skipped)."""
    for j in range(k + 1, len(interactions)):
        _, action, oid = interactions[j]
        if action in ("Open", "Close"):
            continue
        return j if action == "ToggleOn" and _type(oid) == device_type else None
    return None


def plan_steps(actions: Sequence[DriverAction], initial: World, ontology: Ontology) -> list[Step]:
    """What a commander would ask for, step by step, with the driver actions each step covers.

    Only successful interactions count. Opens, closes and pickups belong to the step they serve; a
    ToggleOff or Close right after a step, and putting the knife down after slicing, are tidying-up that
    belongs to the step before. Steps partition ``range(len(actions))``.
    """
    interactions = [
        (i, a.action, a.object_id) for i, a in enumerate(actions) if a.success and a.object_id is not None
    ]
    held: str | None = initial.agent.held
    inside = {oid: obj.parent_id for oid, obj in initial.objects.items()}
    steps: list[Step] = []
    pending = _Pending()
    k = 0
    while k < len(interactions):
        index, action, oid = interactions[k]
        draft: Step | None = None
        last = k
        if action == "Pickup":
            held = oid
            inside[oid] = None
            pending.add(oid)
        elif action == "Slice":
            pending.add(oid)
            draft = Step("slice", 0, 0, obj=_type(oid))
        elif action == "Place" and held is not None:
            put, held, recep = held, None, _type(oid)
            inside[put] = oid
            if ontology.get(recep).pickupable:
                pending.add(oid)
            switch = "Faucet" if recep in WASH_BASINS else recep
            toggle = (
                _next_toggle(interactions, k, switch)
                if recep in WASH_BASINS | SWITCHED_DEVICES.keys()
                else None
            )
            kind: StepKind
            count = 1
            if toggle is not None:
                kind = SWITCHED_DEVICES.get(recep) or _wash_kind(put, initial, ontology)
                last = toggle
                contents = [_type(o) for o, parent in inside.items() if parent == put]
                if kind in MERGEABLE and contents and len(set(contents)) == 1:
                    put, count = contents[0], len(contents)  # "microwave 3 potato slices", not "the bowl"
            elif _is_tool_putdown(steps, put, ontology):
                steps[-1] = replace(steps[-1], end=index + 1)
                pending = _Pending()
                k += 1
                continue
            else:
                kind = "put_slices" if ontology.get(_type(put)).sliced_from else "put"
            draft = Step(kind, 0, 0, held=_type(put), recep=recep, recep_id=oid, count=count)
        elif action == "Pour" and held is not None:
            target = _type(oid)
            empties = target in ontology.pour_basins
            kind = "water_plant" if target == "HousePlant" else "empty" if empties else "pour"
            draft = Step(kind, 0, 0, held=_type(held), recep=target, recep_id=oid)
        elif action == "ToggleOn" and _type(oid) == "Faucet" and (washed := _next_pickup(interactions, k)):
            draft = Step(_wash_kind(washed, initial, ontology), 0, 0, held=_type(washed), recep="SinkBasin")
        elif action in ("ToggleOn", "ToggleOff"):
            kind = "turn_on" if action == "ToggleOn" else "turn_off"
            draft = Step(kind, 0, 0, obj=SPOKEN_AS.get(_type(oid), _type(oid)))
        if draft is not None:
            last = _absorb_tidying(interactions, last)
            start = steps[-1].end if steps else 0
            steps.append(
                replace(draft, start=start, end=interactions[last][0] + 1, targets=tuple(pending.targets))
            )
            pending = _Pending()
            k = last
        k += 1
    return _close_partition(_merge_repeats(steps), len(actions), pending)


def _next_pickup(interactions: Sequence[tuple[int, str, str]], k: int) -> str | None:
    """What is taken out right after the faucet ran (it was under the water): the next Pickup, if the only
    things between are switching the faucet off and doors."""
    for _, action, oid in interactions[k + 1 :]:
        if action == "Pickup":
            return oid
        if action not in ("ToggleOff", "Open", "Close"):
            return None
    return None


def _wash_kind(put: str, initial: World, ontology: Ontology) -> StepKind:
    """Under the faucet a dirty thing is rinsed; a clean container is filled."""
    dirty = put in initial.objects and initial.objects[put].is_dirty
    return "rinse" if dirty or not ontology.get(_type(put)).fillable else "fill"


def _is_tool_putdown(steps: list[Step], put: str, ontology: Ontology) -> bool:
    """Putting the knife down right after slicing is part of the slicing."""
    return bool(steps) and steps[-1].kind == "slice" and _type(put) in ontology.slicing_tools


def _absorb_tidying(interactions: Sequence[tuple[int, str, str]], last: int) -> int:
    while last + 1 < len(interactions) and interactions[last + 1][1] in ("ToggleOff", "Close"):
        last += 1
    return last


def _merge_repeats(steps: list[Step]) -> list[Step]:
    """One step with a count for repeats on one device or receptacle ("toast 2 slices of bread"); a put into
    a device just before it is switched on with more of the same inside counts as one more of those."""
    merged: list[Step] = []
    for step in steps:
        prev = merged[-1] if merged else None
        if (
            prev is not None
            and step.kind in MERGEABLE
            and prev.kind in (step.kind, "put", "put_slices")
            and prev.recep_id == step.recep_id
            and prev.held == step.held
        ):
            targets = tuple(dict.fromkeys(prev.targets + step.targets))
            merged[-1] = replace(step, start=prev.start, count=prev.count + step.count, targets=targets)
        else:
            merged.append(step)
    return merged


def _close_partition(steps: list[Step], n_actions: int, pending: _Pending) -> list[Step]:
    """The last step runs to the end; leftover pickups become a final "pick up" step."""
    if not steps:
        if not pending.targets:
            return []
        return [Step("pickup", 0, n_actions, obj=_type(pending.targets[-1]), targets=tuple(pending.targets))]
    if pending.targets and steps[-1].end < n_actions:
        steps.append(
            Step(
                "pickup",
                steps[-1].end,
                n_actions,
                obj=_type(pending.targets[-1]),
                targets=tuple(pending.targets),
            )
        )
    steps[-1] = replace(steps[-1], end=n_actions)
    return steps


def chunk_steps(steps: Sequence[Step], rng: random.Random, two_steps: float) -> list[Chunk]:
    """Group steps into instructions of one or (with probability ``two_steps``) two steps."""
    chunks: list[Chunk] = []
    i = 0
    while i < len(steps):
        size = 2 if i + 1 < len(steps) and rng.random() < two_steps else 1
        chunks.append(Chunk(tuple(steps[i : i + size])))
        i += size
    return chunks


# ---- saying a step ---------------------------------------------------------------------------------


def _prep(recep: str) -> str:
    return "in" if load_catalog().placement(recep) == "inside" else "on"


def _food(piece: str, ontology: Ontology) -> str | None:
    """The whole a slice comes from (TomatoSliced -> Tomato), for "a slice of tomato"; None if not a slice."""
    try:
        return ontology.get(piece).sliced_from
    except UnknownObjectType:
        return None


def food_name(bank: PhraseBank, rng: random.Random, food: str) -> str:
    """What people call a food when counting its slices ("bread", never "loaf of bread")."""
    return rng.choice(bank.data["foods"].get(food) or bank.object_names(food))


def step_phrase(
    step: Step, tense: Literal["say", "did"], bank: PhraseBank, rng: random.Random, ontology: Ontology
) -> str:
    """The step in the commander's words (``say``) or the follower's report (``did``)."""
    slots: dict[str, str] = {}
    if step.obj is not None:
        slots["obj"] = bank.object_name(rng, step.obj)
    if step.held is not None:
        slots["held"] = bank.object_name(rng, step.held)
        food = _food(step.held, ontology)
        whole = f"the {slots['held']}" if step.count == 1 else f"the {bank.plural(slots['held'])}"
        slots["slices"] = bank.slices(rng, step.count, food_name(bank, rng, food)) if food else whole
        slots["them"] = "it" if step.count == 1 else "them"
    if step.recep is not None:
        slots["recep"] = bank.object_name(rng, step.recep)
        slots["prep"] = _prep(step.recep)
    return bank.say(rng, "steps", step.kind, tense, **slots)


def chunk_phrase(chunk: Chunk, bank: PhraseBank, rng: random.Random, ontology: Ontology) -> str:
    parts = [step_phrase(step, "say", bank, rng, ontology) for step in chunk.steps]
    text = parts[0]
    for part in parts[1:]:
        text = bank.say(rng, "joiners", a=text, b=part)
    return text


# ---- the task in words ------------------------------------------------------------------------------


def _join(items: Sequence[str]) -> str:
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def _ingredients(task: TaskInstance, bank: PhraseBank, rng: random.Random) -> str | None:
    """The parts of a composite dish, from its parameters (TEACh's comments_task_params)."""
    p = task.params

    def sliced(n: str, food: str) -> list[str]:
        return [bank.slices(rng, int(n), food_name(bank, rng, food))] if n.isdigit() and int(n) > 0 else []

    items: list[str] = []
    if task.task_name in ("Sandwich", "Salad"):
        if task.task_name == "Sandwich":
            items.append(bank.slices(rng, 2, "toast"))
        items += sliced(p[0], "Lettuce") + sliced(p[1], "Tomato")
        if task.task_name == "Salad":
            items += [f"{s}, cooked" for s in sliced(p[2], "Potato")]
    elif task.task_name == "Breakfast":
        menu = ((p[0], "coffee"), (p[1], "toast"), (p[6], "sandwich"), (p[9], "salad"))
        items += [bank.pick(rng, "ingredients", dish) for n, dish in menu if n.isdigit() and int(n) > 0]
        for n, food, serving in ((p[2], "Potato", p[3]), (p[4], "Apple", p[5])):
            if n.isdigit() and int(n) > 0:
                slices = bank.slices(rng, 1, food_name(bank, rng, food))
                items.append(
                    bank.say(rng, "ingredients", "serving", slices=slices, y=bank.object_name(rng, serving))
                )
    return _join(items) if items else None


def task_slots(task: TaskInstance, bank: PhraseBank, rng: random.Random) -> dict[str, str]:
    """Words for a task's parameters: {x}, {xs}, {y}, {prep}, {slices}, {them}, {plant}, {ingredients}."""
    p = task.params
    slots: dict[str, str] = {"plant": bank.object_name(rng, "HousePlant")}
    if task.task_name in ("Clean All X", "Boil X"):
        slots["x"] = bank.object_name(rng, p[0])
    elif task.task_name in ("Put All X On Y", "Put All X In One Y"):
        slots.update(x=bank.object_name(rng, p[0]), prep=p[1], y=bank.object_name(rng, p[2]))
    elif task.task_name in ("N Slices Of X In Y", "N Cooked Slices Of X In Y"):
        x = food_name(bank, rng, p[1])
        slots.update(x=x, slices=bank.slices(rng, int(p[0]), x), prep=p[2], y=bank.object_name(rng, p[3]))
        slots["them"] = "it" if p[0] == "1" else "them"
    elif task.task_name == "Breakfast":
        slots["y"] = bank.object_name(rng, p[13])
    if "x" in slots:
        slots["xs"] = bank.plural(slots["x"])
    ingredients = _ingredients(task, bank, rng)
    if ingredients:
        slots["ingredients"] = ingredients
    return slots


def _task_text(task: TaskInstance, which: str, bank: PhraseBank, rng: random.Random) -> str:
    slots = task_slots(task, bank, rng)
    options = [t for t in bank.data["tasks"][task.task_name][which] if template_slots(t) <= slots.keys()]
    return bank.fill(rng.choice(options), **slots)


def task_phrase(task: TaskInstance, bank: PhraseBank, rng: random.Random) -> str:
    """The task as a commander says it: a verb phrase such as "make a salad with 2 slices of tomato"."""
    return _task_text(task, "say", bank, rng)


def alfred_instruction(task: TaskInstance, bank: PhraseBank, rng: random.Random) -> str:
    """One high-level sentence in the style of ALFRED's ``task_desc`` ("Put two tomato slices in a bowl.")."""
    text = _task_text(task, "instruction", bank, rng)
    return text[:1].upper() + text[1:]


# ---- where things are -----------------------------------------------------------------------------


@dataclass(frozen=True)
class PlaceReference:
    """Words for where an object is, and the receptacle they name (None: the floor)."""

    text: str
    receptacle_id: str | None


def _horizontal_gap(a: WorldObject, b: WorldObject) -> float:
    return math.dist((a.center[0], a.center[2]), (b.center[0], b.center[2]))


def _footprints_overlap(a: WorldObject, b: WorldObject) -> bool:
    return all(
        min(a.max_corner[i], b.max_corner[i]) - max(a.min_corner[i], b.min_corner[i]) > STACK_OVERLAP_M
        for i in (0, 2)
    )


def relation_to(world: World, obj: WorldObject, holder: WorldObject, landmark: WorldObject) -> str:
    """How ``holder`` (or ``obj`` on it) sits relative to ``landmark``: above, below, left, right or near.

    Above/below for storage (cabinets, drawers, shelves) whose footprint overlaps the landmark's and that is
    wholly higher or lower (a wall cabinet above the toaster, a drawer under the coffee maker); a counter is
    never "under" the stove standing on it. Otherwise left/right as seen by a person standing in front of
    the landmark, facing it (the landmark's ``facing`` is where its front looks).
    """
    if holder.object_type in STACKED_STORAGE and _footprints_overlap(holder, landmark):
        if holder.bottom >= landmark.top - STACK_OVERLAP_M:
            return "above"
        if holder.top <= landmark.bottom + STACK_OVERLAP_M:
            return "below"
    viewer_yaw = math.radians(landmark.facing + 180)
    right = (math.cos(viewer_yaw), -math.sin(viewer_yaw))  # camera.py: right = (cos θ, −sin θ) in (x, z)
    dx, dz = obj.center[0] - landmark.center[0], obj.center[2] - landmark.center[2]
    sideways = dx * right[0] + dz * right[1]
    if sideways > RELATION_MARGIN_M:
        return "right"
    if sideways < -RELATION_MARGIN_M:
        return "left"
    return "near"


def _landmark_for(
    world: World, obj: WorldObject, holder: WorldObject, landmark_types: Iterable[str]
) -> WorldObject | None:
    """The nearest distinctive fixture to refer to, if the holder needs one (there are several like it)."""
    if len(world.of_type(holder.object_type)) < 2:
        return None
    excluded = {obj.object_id, *world.parent_chain(obj.object_id)}
    wanted = set(landmark_types)
    candidates = [
        o
        for o in world.objects.values()
        if o.object_type in wanted
        and o.object_id not in excluded
        and obj.object_id not in world.parent_chain(o.object_id)
        and o.object_type != holder.object_type
        and _horizontal_gap(o, obj) <= LANDMARK_RANGE_M
    ]
    return min(candidates, key=lambda o: (_horizontal_gap(o, obj), o.object_id), default=None)


def describe_place(world: World, object_id: str, bank: PhraseBank, rng: random.Random) -> PlaceReference:
    """Where an object is, as a commander would say it: "in the fridge", "on the counter left of the sink",
    "in the cabinet above the toaster", "in the pot on the stove"."""
    obj = world.objects[object_id]
    if obj.parent_id is None or obj.parent_id not in world.objects:
        return PlaceReference(bank.pick(rng, "places", "floor"), None)
    parent = world.objects[obj.parent_id]
    text = bank.say(rng, "places", _prep_key(parent), recep=bank.object_name(rng, parent.object_type))
    holder = parent
    grand = world.objects.get(parent.parent_id) if parent.parent_id else None
    if grand is not None and _is_small(parent):
        holder = grand
        text += " " + bank.say(
            rng, "places", _prep_key(grand), recep=bank.object_name(rng, grand.object_type)
        )
    landmark = _landmark_for(world, obj, holder, bank.data["landmarks"])
    if landmark is not None:
        relation = relation_to(world, obj, holder, landmark)
        text = bank.say(
            rng,
            "places",
            "relation",
            base=text,
            rel=bank.pick(rng, "places", relation),
            landmark=bank.object_name(rng, landmark.object_type),
        )
    return PlaceReference(text, parent.object_id)


def _prep_key(receptacle: WorldObject) -> str:
    return "in" if _prep(receptacle.object_type) == "in" else "on"


def _is_small(obj: WorldObject) -> bool:
    """Movable containers (plate, pot, bowl) are described with what they stand on."""
    return max(obj.size) < 0.6


def visible_object_ids(world: World, renderer: Renderer) -> frozenset[str]:
    """Objects with at least one pixel in the driver's current view (a reduced-size render is enough)."""
    frame = renderer.render(world, want_rgb=False)
    return frozenset(frame.object_ids.values())


# ---- the conversation ------------------------------------------------------------------------------


@dataclass
class _Speakers:
    bank: PhraseBank
    rng: random.Random
    voices: dict[TeachSpeaker, Voice]

    def turn(
        self,
        speaker: TeachSpeaker,
        intent: str,
        text: str,
        place: PlaceReference | None = None,
        about: str | None = None,
    ) -> Turn:
        utterance, corrected = typed(text, self.voices[speaker], self.rng)
        receptacle = place.receptacle_id if place is not None else None
        return Turn(speaker, intent, utterance, corrected, about=about, place_receptacle=receptacle)

    def say(self, speaker: TeachSpeaker, intent: str, *path: str, **slots: str) -> Turn:
        return self.turn(speaker, intent, self.bank.say(self.rng, *path, **slots))


def _sentence(text: str) -> str:
    return text if text.endswith(("?", "!", ".", ":")) else text + "."


def write_dialogue(
    task: TaskInstance,
    chunks: Sequence[Chunk],
    worlds: Sequence[World],
    visible: Sequence[frozenset[str]],
    bank: PhraseBank,
    ontology: Ontology,
    rng: random.Random,
    config: DialogueConfig = DialogueConfig(),
) -> Dialogue:
    """The chat around the expert's work: ``worlds[i]``/``visible[i]`` are the state and the driver's view
    when chunk i starts (where-questions are asked and answered about that state)."""
    if not (len(chunks) == len(worlds) == len(visible)):
        raise ValueError(
            f"need one world and view per chunk: {len(chunks)} chunks, {len(worlds)} worlds, "
            f"{len(visible)} views"
        )
    talk = _Speakers(bank, rng, {s: draw_voice(rng, config.typo_rate) for s in ("Commander", "Driver")})
    chance: Callable[[float], bool] = lambda p: rng.random() < p  # noqa: E731
    before: list[tuple[Turn, ...]] = []
    for i, chunk in enumerate(chunks):
        turns: list[Turn] = []
        instruction = chunk_phrase(chunk, bank, rng, ontology)
        if i == 0:
            turns += _opening(talk, task, instruction, chance, config)
        else:
            turns += _report(talk, chunks[i - 1], chance, config, ontology)
            lead = bank.pick(rng, "commander", "next")
            if chance(config.feedback):
                lead = _sentence(bank.pick(rng, "commander", "feedback")) + " " + lead
            turns.append(talk.turn("Commander", "Instruction", f"{lead} {instruction}"))
        if chance(config.ack):
            turns.append(talk.say("Driver", "Acknowledge", "driver", "ack"))
        turns += _where(talk, chunk, worlds[i], visible[i], chance, config, ontology)
        before.append(tuple(turns))
    closing: list[Turn] = []
    if chunks:
        closing += _report(talk, chunks[-1], chance, config, ontology)
    closing.append(talk.say("Commander", "FeedbackPositive", "commander", "close"))
    if chance(config.thanks):
        closing.append(talk.say("Driver", "Thanks", "driver", rng.choice(("thanks", "bye"))))
    return Dialogue(tuple(before), tuple(closing))


def _opening(
    talk: _Speakers,
    task: TaskInstance,
    instruction: str,
    chance: Callable[[float], bool],
    config: DialogueConfig,
) -> list[Turn]:
    bank, rng = talk.bank, talk.rng
    turns: list[Turn] = []
    driver_first = chance(config.driver_opens)
    if driver_first:
        ask = bank.pick(rng, "driver", "ask_task")
        text = f"{bank.pick(rng, 'driver', 'greet')} {ask}" if chance(0.6) else ask
        turns.append(talk.turn("Driver", "RequestForInstruction", text))
    if chance(config.small_talk):
        asker: TeachSpeaker = "Driver" if driver_first else "Commander"
        replier: TeachSpeaker = "Commander" if driver_first else "Driver"
        turns.append(talk.say(asker, "MiscOther", asker.lower(), "small_talk_ask"))
        turns.append(talk.say(replier, "MiscOther", replier.lower(), "small_talk_reply"))
    greet = bank.pick(rng, "commander", "greet") if (not driver_first or chance(0.7)) else ""
    if greet:
        greet += " " if greet.endswith("!") else rng.choice((", ", "! ", ". ", " "))
    goal = _sentence(bank.say(rng, "commander", "task_frame", task=task_phrase(task, bank, rng)))
    first = f"{bank.pick(rng, 'commander', 'first')} {instruction}"
    if chance(config.split_intro):
        turns.append(talk.turn("Commander", "Instruction", greet + goal))
        turns.append(talk.turn("Commander", "Instruction", first))
    else:
        turns.append(talk.turn("Commander", "Instruction", f"{greet}{goal} {first}"))
    return turns


def _report(
    talk: _Speakers, chunk: Chunk, chance: Callable[[float], bool], config: DialogueConfig, ontology: Ontology
) -> list[Turn]:
    bank, rng = talk.bank, talk.rng
    if not chance(config.report):
        return []
    if chance(0.5):
        did = step_phrase(chunk.steps[-1], "did", bank, rng, ontology)
        text = bank.say(rng, "driver", "report_did", did=did)
    else:
        text = bank.pick(rng, "driver", "report")
    if chance(config.ask_next):
        text = f"{_sentence(text)} {bank.pick(rng, 'driver', 'next')}"
    return [talk.turn("Driver", "Acknowledge", text)]


def _where(
    talk: _Speakers,
    chunk: Chunk,
    world: World,
    visible: frozenset[str],
    chance: Callable[[float], bool],
    config: DialogueConfig,
    ontology: Ontology,
) -> list[Turn]:
    """Ask (or be told) where the things this chunk needs are, when the driver cannot see them.

    The first out-of-sight target is asked about or volunteered by chance. A target shut inside a closed
    container is always located in words: the expert walks straight to the right drawer, which a driver
    only does when told (TEACh drivers who are not told open cabinets one by one), so a dialogue that
    never said where the knife is would not explain the reference actions the planner learns from.
    """
    hidden = [t for t in chunk.targets if t in world.objects and t not in visible and t != world.agent.held]
    turns: list[Turn] = []
    for number, target in enumerate(hidden):
        enclosed = _enclosed(world, target, ontology)
        if number > 0 and not enclosed:
            continue
        bank, rng = talk.bank, talk.rng
        place = describe_place(world, target, bank, rng)
        name = bank.object_name(rng, world.objects[target].object_type)
        if chance(config.ask_where):
            ask = talk.say(
                "Driver", "RequestForObjectLocationAndOtherDetails", "driver", "ask_where", obj=name
            )
            answer = bank.say(rng, "commander", "where_answer", obj=name, where=place.text)
            turns += [ask, talk.turn("Commander", "InformationOnObjectDetails", answer, place, target)]
        elif enclosed or chance(config.volunteer_where):
            text = bank.say(rng, "commander", "where_volunteer", obj=name, where=place.text)
            turns.append(talk.turn("Commander", "InformationOnObjectDetails", text, place, target))
    return turns


def _enclosed(world: World, object_id: str, ontology: Ontology) -> bool:
    """Whether the object lies inside a closed container (a fridge, drawer or cabinet with its door shut)."""
    holders = [world.objects[h] for h in world.parent_chain(object_id) if h in world.objects]
    return any(
        not h.is_open and ontology.get(h.object_type).openable and ontology.get(h.object_type).receptacle
        for h in holders
    )
