"""A decoder vocabulary of whole plan words: one token per subgoal action and per object type.

A plan is a sequence of (action, type) pairs, so a decoder that writes word pieces spends three to five
steps and a 30k-way softmax per subgoal, and can misspell a type. The MiniLM recipe's decoder writes from
this vocabulary instead: two tokens per subgoal, no separators, every token a real action or type, and a
grammar (action, type, action, type, ..., end) that beam search is held to
(``allowed_next``). The text form (DESIGN.md §5) is rebuilt on decoding. Saved beside the weights as
``plan_vocab.json``; a checkpoint without it decodes with its tokenizer as any seq2seq model does.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from symbolic.ontology import Ontology
from symbolic.subgoals import SubgoalAction, parse_subgoals

PLAN_VOCAB_FILE = "plan_vocab.json"
PAD, START, END = "<pad>", "<s>", "</s>"
SPECIALS: tuple[str, ...] = (PAD, START, END)


@dataclass(frozen=True)
class PlanVocabulary:
    """Token ids: 0 pad, 1 start, 2 end, then the subgoal actions, then the object types."""

    actions: tuple[str, ...]
    types: tuple[str, ...]

    @classmethod
    def from_ontology(cls, ontology: Ontology) -> PlanVocabulary:
        return cls(tuple(a.value for a in SubgoalAction), tuple(ontology.types))

    @property
    def words(self) -> tuple[str, ...]:
        return (*SPECIALS, *self.actions, *self.types)

    def __len__(self) -> int:
        return len(SPECIALS) + len(self.actions) + len(self.types)

    @property
    def pad_id(self) -> int:
        return 0

    @property
    def start_id(self) -> int:
        return 1

    @property
    def end_id(self) -> int:
        return 2

    def action_ids(self) -> list[int]:
        return list(range(len(SPECIALS), len(SPECIALS) + len(self.actions)))

    def type_ids(self) -> list[int]:
        first = len(SPECIALS) + len(self.actions)
        return list(range(first, first + len(self.types)))

    def encode(self, plan: str, ontology: Ontology) -> list[int]:
        """A plan in §5's text form -> ids ending with the end id (no start id)."""
        index = {word: i for i, word in enumerate(self.words)}
        ids = []
        for subgoal in parse_subgoals(plan, ontology):
            ids += [index[subgoal.action.value], index[subgoal.obj]]
        return ids + [self.end_id]

    def decode(self, ids: Sequence[int]) -> str:
        """Generated ids -> §5's text form; specials are skipped and a dangling action is dropped."""
        words = self.words
        kept = [words[i] for i in ids if 0 <= i < len(words) and words[i] not in SPECIALS]
        pairs = [f"{kept[k]} {kept[k + 1]}" for k in range(0, len(kept) - 1, 2)]
        return ", ".join(pairs)

    def allowed_next(self, generated: Sequence[int]) -> list[int]:
        """Ids the grammar allows after ``generated`` (which starts with the start id): an action or the
        end after a complete pair, a type after an action, padding once ended."""
        pad, start = self.pad_id, self.start_id
        body = [i for i in generated if i != pad and i != start]
        if body and body[-1] == self.end_id:
            return [self.pad_id]
        if len(body) % 2 == 1:
            return self.type_ids()
        return [*self.action_ids(), self.end_id]

    def save(self, folder: Path) -> None:
        data = {"actions": list(self.actions), "types": list(self.types)}
        (folder / PLAN_VOCAB_FILE).write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")

    @classmethod
    def load(cls, folder: Path) -> PlanVocabulary | None:
        """The folder's plan vocabulary, or None when its decoder writes tokenizer pieces."""
        path = folder / PLAN_VOCAB_FILE
        if not path.is_file():
            return None
        data = json.loads(path.read_text(encoding="utf-8"))
        return cls(tuple(data["actions"]), tuple(data["types"]))
