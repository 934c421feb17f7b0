"""Make a plan cover the number of things the commander asked for: counts and "x and y" (issue 62).

The language planner writes one Pickup/Place (or clean, toast, ...) cycle for an object where the commander
asked for two ("clean two plates"), and the first object's cycle alone where two were joined ("clean a mug
and a pan"). Repair expands "Slice needs a knife" from the ontology; this pass expands the request from the
words (``symbolic.request_words``), and it does so with the model's own cycle: the subgoals from the
object's Pickup (and the Navigate to it) until another object is picked up. A count repeats the cycle until
the plan holds as many as were asked; an object joined to one the plan handles gets that object's cycle
with its own type ("clean a mug and a pan" gives the pan the mug's Navigate, Pickup, Place SinkBasin,
ToggleOn Faucet, ToggleOff Faucet). An object the plan cuts (or switches, opens) where it stands instead of
carrying it has no cycle, and a joined object then gets those steps ("cut a tomato and a lettuce" gives the
tomato Navigate, Slice, in the order said). Cycles already done (the history subgoals of EDH, or what the
agent completed before a re-plan) count toward the number.

It only adds: nothing the model planned is removed, a number no cycle can be found for changes nothing,
and a cycle is given to another type only if that type affords every step of it (a kettle does not get a
mug's coffee-machine cycle). "All the forks" gives no number, and the executor has no "every one it finds"
subgoal, so "all" without a number is left as the model planned it. Each change is a ``RepairEvent``
(rules ``request-count`` and ``request-conjunction``) so the session's repair log shows it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence, Set
from dataclasses import dataclass

from symbolic.ontology import Ontology
from symbolic.predicates import affordance_failure
from symbolic.repair import REQUEST_CONJUNCTION, REQUEST_COUNT, RepairEvent
from symbolic.request_words import Group, Mention, Request
from symbolic.subgoals import Subgoal, SubgoalAction

A = SubgoalAction


@dataclass(frozen=True)
class Cycle:
    """One object's cycle in the history + plan: subgoals ``[start, end)``, made for ``obj``."""

    obj: str
    start: int
    end: int


def _cycle_object(plan: Sequence[Subgoal], asked: str, ontology: Ontology) -> str:
    """The type whose Pickups carry an asked-for object: its pieces when the plan picks up pieces
    ("a tomato and a lettuce" in a salad are picked up as TomatoSliced, LettuceSliced)."""
    piece = ontology.get(asked).sliced_into
    if piece is not None and Subgoal(A.PICKUP, piece) in plan:
        return piece
    return asked


def cycles(plan: Sequence[Subgoal], obj: str, ontology: Ontology) -> list[Cycle]:
    """The cycles of ``obj`` in ``plan``, in order: one per ``obj`` handled.

    A span starts at a Pickup of ``obj`` (with the Navigate to it just before) and runs until the plan
    picks up something else (that Pickup's Navigate excluded) or ends; steps after the object is put away
    that are not about where it went are left out (``_trimmed_end``). Within a span each Pickup of ``obj``
    starts another one, unless it takes back the same one (``_takes_back``): toast picked up from the
    toaster to go on the plate, a mug from the sink it was rinsed in."""
    found: list[Cycle] = []
    index = 0
    while index < len(plan):
        if plan[index] != Subgoal(A.PICKUP, obj):
            index += 1
            continue
        end = index + 1
        while end < len(plan) and not (plan[end].action is A.PICKUP and plan[end].obj != obj):
            end += 1
        if end < len(plan) and end - 1 > index and plan[end - 1] == Subgoal(A.NAVIGATE, plan[end].obj):
            end -= 1
        found += _split(plan, obj, index, _trimmed_end(plan, index, end, ontology), ontology)
        index = end
    return found


def _split(plan: Sequence[Subgoal], obj: str, first: int, end: int, ontology: Ontology) -> list[Cycle]:
    """A span's cycles: a new one at every Pickup of ``obj`` that does not take back the same one."""
    pickups = [i for i in range(first, end) if plan[i] == Subgoal(A.PICKUP, obj)]
    pieces = [
        [g for g in plan[a:b] if g.action is not A.NAVIGATE]
        for a, b in zip(pickups, [*pickups[1:], end], strict=True)
    ]
    starts, cycle_piece = [first], pieces[0]
    for number in range(1, len(pieces)):
        if not _takes_back(pieces[number - 1], pieces[number], cycle_piece, ontology):
            starts.append(pickups[number])
            cycle_piece = pieces[number]
    starts = [s - 1 if s > 0 and plan[s - 1] == Subgoal(A.NAVIGATE, obj) else s for s in starts]
    return [Cycle(obj, s, e) for s, e in zip(starts, [*starts[1:], end], strict=True)]


def _takes_back(
    before: Sequence[Subgoal], piece: Sequence[Subgoal], cycle_start: Sequence[Subgoal], ontology: Ontology
) -> bool:
    """Whether a Pickup (beginning ``piece``) takes back the object of the piece ``before`` it: that one
    was put into something that was then worked (switched, opened or closed: the toaster, the faucet over
    the sink, the fridge), and ``piece`` is not the cycle's first piece again (nobody rinses the same mug
    twice: "rinse, rinse" is two mugs)."""
    places = [i for i, g in enumerate(before) if g.action is A.PLACE]
    if not places or places[-1] == len(before) - 1:
        return False
    receptacle = before[places[-1]].obj
    if not all(_works_on(g.obj, receptacle, ontology) for g in before[places[-1] + 1 :]):
        return False
    return list(piece) != list(cycle_start)


def _trimmed_end(plan: Sequence[Subgoal], pickup: int, end: int, ontology: Ontology) -> int:
    """Where a span's cycle ends: after the last Place of the object and what is then done to the
    receptacle it went to (closing it, switching it or its faucet or knob on and off); steps on other
    things after that ("..., Place Fridge, Close Fridge, Navigate Microwave, ToggleOn Microwave") are the
    plan's next task, not part of the cycle."""
    places = [i for i in range(pickup + 1, end) if plan[i].action is A.PLACE]
    if not places:
        return end
    receptacle = plan[places[-1]].obj
    cut = places[-1] + 1
    while cut < end and plan[cut].action is not A.NAVIGATE and _works_on(plan[cut].obj, receptacle, ontology):
        cut += 1
    return cut


def _works_on(obj: str, receptacle: str, ontology: Ontology) -> bool:
    return (
        obj == receptacle
        or ontology.same_place(obj, receptacle)
        or receptacle in ontology.controls.get(obj, ())
    )


def _repeats(plan: Sequence[Subgoal], obj: str, start: int, end: int) -> list[Cycle]:
    """Split a span into its repeated cycles by the smallest period of its interactions (Navigate steps
    left out, since repair adds them where the model did not)."""
    positions = [i for i in range(start, end) if plan[i].action is not A.NAVIGATE]
    actions = [plan[i] for i in positions]
    n = len(actions)
    for period in range(1, n // 2 + 1):
        if n % period or actions[:period] * (n // period) != actions or actions[0] != Subgoal(A.PICKUP, obj):
            continue
        starts = [positions[k] for k in range(0, n, period)]
        starts = [s - 1 if s > start and plan[s - 1] == Subgoal(A.NAVIGATE, obj) else s for s in starts]
        starts[0] = start
        return [Cycle(obj, s, e) for s, e in zip(starts, [*starts[1:], end], strict=True)]
    return [Cycle(obj, start, end)]


def retyped(cycle: Sequence[Subgoal], old: str, new: str, ontology: Ontology) -> list[Subgoal] | None:
    """The cycle of ``old`` with ``new`` in its place (the whole it is sliced from too: Tomato for
    TomatoSliced), or None when ``new`` cannot do a step of it (``renamed``)."""
    renames = {old: new}
    old_whole, new_whole = ontology.get(old).sliced_from, ontology.get(new).sliced_from
    if old_whole is not None and new_whole is not None:
        renames[old_whole] = new_whole
    return renamed(cycle, renames, ontology, checked={new})


def renamed(
    plan: Sequence[Subgoal],
    renames: Mapping[str, str],
    ontology: Ontology,
    checked: Set[str],
    *,
    as_receptacles: bool = False,
) -> list[Subgoal] | None:
    """``plan`` with each type in ``renames`` replaced, or None when a replaced type cannot do a step: an
    action it does not afford, or a Place of a thing in ``checked`` (or, ``as_receptacles``, into one) that
    the receptacle does not take."""
    copy: list[Subgoal] = []
    held: str | None = None
    for subgoal in plan:
        changed = Subgoal(subgoal.action, renames.get(subgoal.obj, subgoal.obj))
        if affordance_failure(ontology, changed) is not None:
            return None
        if changed.action is A.PICKUP:
            held = changed.obj
        elif changed.action is A.PLACE:
            watched = held in checked or (as_receptacles and changed.obj in checked)
            if held is not None and watched and not ontology.accepts(changed.obj, held):
                return None
            held = None
        copy.append(changed)
    return copy


@dataclass
class _Plan:
    """History + plan being extended; only positions from ``done`` on may change."""

    subgoals: list[Subgoal]
    done: int
    log: list[RepairEvent]

    def insert(self, at: int, added: Sequence[Subgoal], rule: str, reason: str) -> None:
        at = max(at, self.done)
        self.subgoals[at:at] = added
        self.log.append(RepairEvent(rule, at - self.done, reason, (), tuple(added)))


def cover_request(
    plan: Sequence[Subgoal],
    request: Request,
    ontology: Ontology,
    history: Sequence[Subgoal] = (),
) -> tuple[list[Subgoal], list[RepairEvent]]:
    """``plan`` extended so that, with ``history`` done before it, it holds a cycle for every object the
    request names in a group and as many cycles as a number says; the events say what was added and why."""
    state = _Plan([*history, *plan], len(history), [])
    for mention in _counted(request):
        _cover_count(state, mention, ontology)
    for group in request.groups:
        _cover_group(state, group, request, ontology)
    return state.subgoals[state.done :], state.log


def _counted(request: Request) -> list[Mention]:
    """For each type with a number said, the mention that said the largest, in the order of the words."""
    chosen: dict[str, Mention] = {}
    for mention in request.mentions:
        best = request.count_of(mention.object_type)
        if best is not None and best[0] >= 2:
            chosen.setdefault(mention.object_type, best[1])
    return list(chosen.values())


def _cover_count(state: _Plan, mention: Mention, ontology: Ontology) -> None:
    asked = mention.count or 1
    obj = _cycle_object(state.subgoals, mention.object_type, ontology)
    found = cycles(state.subgoals, obj, ontology)
    if not found or len(found) >= asked:
        return
    last = found[-1]
    copies = asked - len(found)
    added = _another(state.subgoals[last.start : last.end], obj) * copies
    state.insert(
        last.end,
        added,
        REQUEST_COUNT,
        f"the commander asked for {asked} ({mention.words!r}) and the plan handles {len(found)} {obj}: "
        f"its {obj} cycle repeated {copies} more time{'s' if copies > 1 else ''}",
    )


WORKED_ON = frozenset({A.SLICE, A.TOGGLE_ON, A.TOGGLE_OFF, A.OPEN, A.CLOSE})
"""Actions on the object itself, not on what is put in it (Place, Pour): what ``worked_on`` spans hold."""


def worked_on(plan: Sequence[Subgoal], obj: str) -> list[Cycle]:
    """The spans in which the plan works ``obj`` where it stands: its own steps of ``WORKED_ON`` in a row,
    with the Navigate to it before ("Navigate Lettuce, Slice Lettuce"). A joined object that is cut rather
    than carried ("cut a tomato and a lettuce") has no cycle, and copies one of these instead."""
    found: list[Cycle] = []
    index = 0
    while index < len(plan):
        if plan[index].obj != obj or plan[index].action not in WORKED_ON:
            index += 1
            continue
        start = index - 1 if index > 0 and plan[index - 1] == Subgoal(A.NAVIGATE, obj) else index
        end = index + 1
        while end < len(plan) and plan[end].obj == obj and plan[end].action in WORKED_ON:
            end += 1
        found.append(Cycle(obj, start, end))
        index = end
    return found


def _handled(plan: Sequence[Subgoal], obj: str, ontology: Ontology) -> list[Cycle]:
    """The plan's cycles of ``obj``, else the spans that work on it where it stands."""
    return cycles(plan, obj, ontology) or worked_on(plan, obj)


def _cover_group(state: _Plan, group: Group, request: Request, ontology: Ontology) -> None:
    for position, mention in enumerate(group.members):
        obj = _cycle_object(state.subgoals, mention.object_type, ontology)
        if _handled(state.subgoals, obj, ontology):
            continue
        source = _nearest_handled(state, group.members, position, ontology)
        if source is None:
            return  # the model planned none of the joined objects: nothing to copy the shape of
        source_mention, source_cycles = source
        template = state.subgoals[source_cycles[-1].start : source_cycles[-1].end]
        target = _target_type(source_cycles[-1].obj, mention.object_type, ontology)
        copy = retyped(template, source_cycles[-1].obj, target, ontology) if target else None
        if target is None or copy is None:
            continue  # no pieces of it, or a step of the cycle it cannot do
        counted = request.count_of(mention.object_type)
        copies = counted[0] if counted else 1
        copy = _another(copy, target)
        before = group.members.index(source_mention) > position
        at = source_cycles[0].start if before else source_cycles[-1].end
        state.insert(
            at,
            copy * copies,
            REQUEST_CONJUNCTION,
            f"the commander asked for {group.words!r} and the plan handles {source_mention.object_type} "
            f"but no {mention.object_type}: the {source_cycles[-1].obj} cycle copied for {target}"
            + (f" {copies} times" if copies > 1 else ""),
        )


def _another(cycle: Sequence[Subgoal], obj: str) -> list[Subgoal]:
    """A copied cycle fetches another ``obj``: it starts by going to one even where the model's cycle
    picked up the first where it stood (a second slice is not where the first was put), and it does not
    close a container it did not open (the fridge the first mug happened to be in)."""
    copy: list[Subgoal] = []
    for subgoal in cycle:
        if subgoal.action is A.CLOSE and Subgoal(A.OPEN, subgoal.obj) not in copy:
            if copy and copy[-1] == Subgoal(A.NAVIGATE, subgoal.obj):
                copy.pop()
            continue
        copy.append(subgoal)
    navigate = Subgoal(A.NAVIGATE, obj)
    return copy if copy and copy[0] == navigate else [navigate, *copy]


def _nearest_handled(
    state: _Plan, group: Sequence[Mention], position: int, ontology: Ontology
) -> tuple[Mention, list[Cycle]] | None:
    """The joined mention nearest before (else after) ``position`` whose object the plan handles (cycles,
    else spans that work on it)."""
    order = [*range(position - 1, -1, -1), *range(position + 1, len(group))]
    for index in order:
        other = group[index]
        found = _handled(state.subgoals, _cycle_object(state.subgoals, other.object_type, ontology), ontology)
        if found:
            return other, found
    return None


def _target_type(source_obj: str, asked: str, ontology: Ontology) -> str | None:
    """What the copy handles: the asked type, or its pieces when the source cycle handles pieces."""
    if ontology.get(source_obj).sliced_from is not None and ontology.get(asked).sliced_from is None:
        return ontology.get(asked).sliced_into
    return asked
