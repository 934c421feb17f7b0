"""What decodes plans: the engine contract, transformers' ``generate`` engine, and the registry.

"torch" is ``generate`` on the loaded model, for any seq2seq checkpoint (BART, T5, a user's own) and the
path training's code uses; "onnx" (``onnx_engine.py``) runs graphs exported from the same weights with
ONNX Runtime under our copy of ``generate``'s beam search, for ``minilm-encdec`` checkpoints with a plan
vocabulary, with the same plans for a fraction of the CPU time (``bench/planner_latency.py`` records both
side by side and how often their plans agree). "auto" is onnx where it applies, else torch.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from types import MappingProxyType
from typing import Protocol

import torch

from models.planner.config import DecodeEngine
from models.planner.modeling import PlannerModel


@dataclass(frozen=True)
class Candidate:
    """One finished beam: the raw generated plan and its score (log-probability over generated length)."""

    text: str
    score: float


class PlanDecoder(Protocol):
    """Formatted planner inputs -> raw generated plans (DESIGN.md §5's text form)."""

    def generate_texts(self, sources: Sequence[str]) -> list[str]:
        """The best plan of each input."""
        ...

    def generate_candidates(self, sources: Sequence[str]) -> list[list[Candidate]]:
        """Each input's finished beams, best first (the first is ``generate_texts``' plan)."""
        ...


@dataclass(frozen=True)
class DecodeSettings:
    """Beam search as ``SubgoalGenerator`` resolved it for one checkpoint."""

    num_beams: int
    max_source_tokens: int  # longer inputs keep their end
    max_new_tokens: int
    bias: dict[int, float]  # decoder token id -> logit added at every step (the Navigate bias)


class TorchPlanDecoder:
    """transformers' ``generate``: batches padded together, beam search held to the plan grammar when the
    decoder writes plan words, else decoded with the tokenizer."""

    def __init__(self, planner: PlannerModel, settings: DecodeSettings) -> None:
        self.planner = planner
        self.settings = settings

    def generate_texts(self, sources: Sequence[str]) -> list[str]:
        return [candidates[0].text for candidates in self._generate(sources, returned=1)]

    def generate_candidates(self, sources: Sequence[str]) -> list[list[Candidate]]:
        return self._generate(sources, returned=self.settings.num_beams)

    def _generate(self, sources: Sequence[str], returned: int) -> list[list[Candidate]]:
        """The ``returned`` best finished beams of each input (the search is the same either way; asking
        for one skips decoding and scoring the others)."""
        tokenizer = self.planner.tokenizer
        vocab = self.planner.plan_vocab
        grammar = None
        if vocab is not None:

            def grammar(_: int, generated: torch.Tensor) -> list[int]:
                return vocab.allowed_next(generated.tolist())

        tokenizer.truncation_side = "left"  # long dialogues keep their latest turns and the history
        encoded = tokenizer(
            list(sources),
            return_tensors="pt",
            padding=True,
            truncation=True,
            max_length=self.settings.max_source_tokens,
        )
        bias = {(token,): value for token, value in self.settings.bias.items()}
        scored = returned > 1
        with torch.inference_mode():
            output = self.planner.model.generate(  # type: ignore[operator]
                input_ids=encoded["input_ids"],
                attention_mask=encoded["attention_mask"],
                num_beams=self.settings.num_beams,
                num_return_sequences=returned,
                max_new_tokens=self.settings.max_new_tokens,
                early_stopping=True,
                prefix_allowed_tokens_fn=grammar,
                sequence_bias=bias or None,
                return_dict_in_generate=True,
                output_scores=scored,
            )
        rows = output.sequences
        if vocab is not None:
            texts = [vocab.decode(row.tolist()) for row in rows]
        else:
            texts = [text.strip() for text in tokenizer.batch_decode(rows, skip_special_tokens=True)]
        scores = output.sequences_scores.tolist() if scored else [0.0] * len(texts)
        found = [Candidate(text, score) for text, score in zip(texts, scores, strict=True)]
        return [found[i : i + returned] for i in range(0, len(found), returned)]


def onnx_applies(planner: PlannerModel) -> bool:
    """The onnx engine runs ``minilm-encdec`` models (BERT encoder and decoder) with a plan vocabulary."""
    from models.planner.onnx_graphs import graphs_support

    return planner.plan_vocab is not None and graphs_support(planner.model)


def _torch(planner: PlannerModel, settings: DecodeSettings) -> PlanDecoder:
    return TorchPlanDecoder(planner, settings)


def _onnx(planner: PlannerModel, settings: DecodeSettings) -> PlanDecoder:
    vocab = planner.plan_vocab
    if vocab is None or not onnx_applies(planner):
        has = "a" if vocab is not None else "no"
        where = planner.path or "this planner"
        raise ValueError(
            f"engine 'onnx' runs minilm-encdec checkpoints with a plan vocabulary; {where} is a "
            f"{type(planner.model).__name__} with {has} plan vocabulary: use engine 'torch'"
        )
    from models.planner.beam_search import BeamSettings
    from models.planner.onnx_engine import OnnxPlanDecoder  # onnxruntime loads here, not at import

    beams = BeamSettings(
        num_beams=settings.num_beams,
        start_id=vocab.start_id,
        end_id=vocab.end_id,
        max_new_tokens=settings.max_new_tokens,
    )
    return OnnxPlanDecoder(
        planner.model,  # type: ignore[arg-type]  # an EncoderDecoderModel: checked by onnx_applies
        planner.tokenizer,
        vocab,
        beams,
        settings.max_source_tokens,
        settings.bias,
        threads=torch.get_num_threads(),
    )


ENGINES: MappingProxyType[str, Callable[[PlannerModel, DecodeSettings], PlanDecoder]] = MappingProxyType(
    {"torch": _torch, "onnx": _onnx}
)
"""Engine name -> factory from the loaded planner and its decode settings."""


def resolve_engine(name: DecodeEngine, planner: PlannerModel) -> str:
    """The engine "auto" stands for with this planner; any other name as it is."""
    if name != "auto":
        return name
    return "onnx" if onnx_applies(planner) else "torch"


def make_decoder(name: DecodeEngine, planner: PlannerModel, settings: DecodeSettings) -> PlanDecoder:
    """The engine ``name`` on ``planner``; ValueError lists the known names for an unknown one."""
    resolved = resolve_engine(name, planner)
    factory = ENGINES.get(resolved)
    if factory is None:
        raise ValueError(
            f"no planner engine named {name!r}; known engines: auto, {', '.join(sorted(ENGINES))}"
        )
    return factory(planner, settings)
