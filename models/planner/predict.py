"""Generate plans with beam search and make every output a valid plan over the ontology, saying what changed.

The seed decodes with a beam of 4 (appendix A). A generated plan is text, and a small model can write a
name that is no AI2-THOR type ("butterknif", "coffeemachin") or an item without an action. Each item is
parsed on its own: an unknown object name is mapped to the nearest type the ontology suggests, an item
that cannot be read is dropped, and each such decision is returned as a ``ValidationNote`` so the agent can
log it next to the repair log.
"""

from __future__ import annotations

import re
import threading
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from models.planner.config import GenerationConfig
from models.planner.engines import DecodeSettings, make_decoder, resolve_engine
from models.planner.hub import trained_input_length, writable_tokens
from models.planner.modeling import (
    PlannerModel,
    encoder_positions,
    load_planner_model,
    missing_marks,
    read_planner_meta,
)
from models.planner.text import COMMANDER_MARK, INSTRUCTION_MARK
from symbolic.ontology import Ontology, UnknownObjectType
from symbolic.subgoals import Subgoal, SubgoalAction, SubgoalSyntaxError, parse_subgoals

NoteKind = Literal["mapped", "dropped"]
_ITEMS = re.compile(r"[,;\n]+")
DEFAULT_SOURCE_TOKENS = 512  # for models without a position table (T5) or a run config
_MAX_MAPPINGS_PER_ITEM = 4  # an item holds at most a few subgoals ("navigate x pickup x")


@dataclass(frozen=True)
class ValidationNote:
    """One change made to a generated item: its position, the text, what was done and why."""

    item_index: int
    item: str
    kind: NoteKind
    detail: str
    subgoals: tuple[Subgoal, ...] = ()
    """What the item became (empty when dropped)."""


@dataclass(frozen=True)
class PlanPrediction:
    """The raw generated text, the validated plan, and the notes on what validation changed."""

    text: str
    subgoals: tuple[Subgoal, ...]
    notes: tuple[ValidationNote, ...]
    score: float | None = None  # the beam's log-probability over its length, when candidates were asked for


def _parse_item(item: str, index: int, ontology: Ontology) -> tuple[list[Subgoal], list[ValidationNote]]:
    """Parse one item, replacing unknown names by the ontology's nearest suggestion, else dropping it."""
    original, mapped = item, []
    for _ in range(_MAX_MAPPINGS_PER_ITEM):
        try:
            subgoals = parse_subgoals(item, ontology)
        except UnknownObjectType as error:
            if not error.suggestions or error.name not in item:
                detail = f"unknown object {error.name!r} with no type near it"
                return [], [ValidationNote(index, original, "dropped", detail)]
            mapped.append(f"{error.name!r} -> {error.suggestions[0]}")
            item = item.replace(error.name, error.suggestions[0], 1)
            continue
        except SubgoalSyntaxError as error:
            return [], [ValidationNote(index, original, "dropped", str(error))]
        notes = []
        if mapped:
            detail = "unknown object mapped to the nearest type: " + ", ".join(mapped)
            notes.append(ValidationNote(index, original, "mapped", detail, tuple(subgoals)))
        return subgoals, notes
    return [], [ValidationNote(index, original, "dropped", "too many unknown names in one item")]


def validate_generated_plan(text: str, ontology: Ontology) -> tuple[list[Subgoal], list[ValidationNote]]:
    """Generated text -> subgoals over the ontology, with a note for each mapped or dropped item."""
    subgoals: list[Subgoal] = []
    notes: list[ValidationNote] = []
    items = [item.strip() for item in _ITEMS.split(text)]
    for index, item in enumerate(i for i in items if i):
        parsed, item_notes = _parse_item(item, index, ontology)
        subgoals += parsed
        notes += item_notes
    return subgoals, notes


def source_token_limit(planner: PlannerModel) -> int:
    """The input length the model was trained with (its run config), else its position table's size."""
    meta = read_planner_meta(planner.path) if planner.path is not None else {}
    trained = trained_input_length(meta)
    if trained is not None:
        return trained
    return encoder_positions(planner.model) or DEFAULT_SOURCE_TOKENS


def target_token_limit(planner: PlannerModel) -> int:
    """Tokens the decoder can write (``hub.writable_tokens``), or unlimited for models without a table."""
    limit = writable_tokens(planner.model.config)
    return limit if limit is not None else 1_000_000


NAVIGATE_BIAS_KEY = "navigate_bias"
"""planner_meta.json's calibrated Navigate bias (``calibrate``)."""


def navigate_bias(planner: PlannerModel, generation: GenerationConfig) -> float:
    """The logit added to the Navigate word while decoding: the caller's, else the checkpoint's calibrated
    one, else 0. Why a bias at all: the reference plans write ``Navigate X`` wherever the expert happened to
    walk, which the words seldom decide, and a beam of 4 prefers the shorter plan; uncalibrated, the default
    checkpoint left out a Navigate the reference had in 56 of its 61 EDH misses that differ only in
    Navigate steps. Only decoders with a plan vocabulary (one word per action) take it."""
    if generation.navigate_bias is not None:
        return generation.navigate_bias
    meta = read_planner_meta(planner.path) if planner.path is not None else {}
    value = meta.get(NAVIGATE_BIAS_KEY, 0.0)
    return float(value) if isinstance(value, int | float) else 0.0


TORCH_LOCK = threading.Lock()
"""One planner model loads or generates at a time in this process. Loading through transformers switches
torch to the meta device (its empty-weights initialisation) for every thread, so a generation running
beside a load failed with "Tensor on device cpu is not on the expected device meta" (two sessions created
at once on a fresh service); generations on 2 cores gain nothing in parallel anyway."""


class SubgoalGenerator:
    """A loaded planner model that turns formatted inputs into validated plans (beam search on the
    ``generation.engine``, built once here: the onnx engine exports its graphs now, not on the first call)."""

    def __init__(
        self, planner: PlannerModel, ontology: Ontology, generation: GenerationConfig | None = None
    ) -> None:
        self.planner = planner
        self.ontology = ontology
        self.generation = generation or GenerationConfig()
        self.max_source_tokens = source_token_limit(planner)
        self.max_new_tokens = min(self.generation.max_new_tokens, target_token_limit(planner))
        self.navigate_bias = navigate_bias(planner, self.generation)
        self.reads_instruction_mark = INSTRUCTION_MARK not in missing_marks(planner.tokenizer)
        self.engine = resolve_engine(self.generation.engine, planner)
        settings = DecodeSettings(
            num_beams=self.generation.num_beams,
            max_source_tokens=self.max_source_tokens,
            max_new_tokens=self.max_new_tokens,
            bias=self._token_bias(),
        )
        with TORCH_LOCK:  # an export traces torch code, which a load in another thread would disturb
            self.decoder = make_decoder(self.generation.engine, planner, settings)

    def readable(self, source: str) -> str:
        """``source`` as this model was trained to read it: a checkpoint from before the <INS> mark was
        trained on ALFRED goals as the commander's only turn, so it gets them that way (its tokenizer would
        cut an unknown mark into pieces)."""
        if self.reads_instruction_mark:
            return source
        return source.replace(INSTRUCTION_MARK, COMMANDER_MARK)

    @classmethod
    def from_directory(
        cls, path: Path, ontology: Ontology, generation: GenerationConfig | None = None
    ) -> SubgoalGenerator:
        with TORCH_LOCK:
            model = load_planner_model(path)
        return cls(model, ontology, generation)

    def generate_texts(self, sources: Sequence[str]) -> list[str]:
        """Raw decoded plans for a batch of inputs (inputs longer than the model allows keep their end).

        A decoder with a plan vocabulary is held to the plan grammar (action, type, ..., end) during beam
        search and decoded word by word; any other seq2seq model decodes with its tokenizer."""
        if not sources:
            return []
        with TORCH_LOCK:
            return self.decoder.generate_texts([self.readable(source) for source in sources])

    def _token_bias(self) -> dict[int, float]:
        vocab = self.planner.plan_vocab
        if vocab is None or not self.navigate_bias:
            return {}
        return {vocab.words.index(SubgoalAction.NAVIGATE.value): self.navigate_bias}

    def predict_many(self, sources: Sequence[str]) -> list[PlanPrediction]:
        return [self._validated(text) for text in self.generate_texts(sources)]

    def predict(self, source: str) -> PlanPrediction:
        """The validated plan for one formatted input (``text.format_planner_input``)."""
        return self.predict_many([source])[0]

    def predict_candidates(self, source: str) -> list[PlanPrediction]:
        """Every finished beam for one input as a validated plan, best first: the first is ``predict``'s,
        the others the readings the model ranked next (which object a word means, mostly)."""
        with TORCH_LOCK:
            (candidates,) = self.decoder.generate_candidates([self.readable(source)])
        return [self._validated(candidate.text, candidate.score) for candidate in candidates]

    def _validated(self, text: str, score: float | None = None) -> PlanPrediction:
        subgoals, notes = validate_generated_plan(text, self.ontology)
        return PlanPrediction(text=text, subgoals=tuple(subgoals), notes=tuple(notes), score=score)
