"""The planner on ONNX Runtime: the encoder graph once per input, the step graph under ``beam_search``.

Why: the same plans as ``generate`` for a fraction of its CPU time at one thread (``bench/planner_latency.py``
records both side by side, and how often their plans agree). Float32 throughout: the encoder's arithmetic
is most of what is left, and int8 dynamic quantization of its linear layers (``quantize_dynamic``) changed
8 of the 35 plans that bench times, as did int8 applied to the whole model under ``generate`` (6 of 35).

Nothing is written to disk (``models/onnx_runtime.py``): each graph is exported to memory when the
planner loads, about 2-5 s once per process at service start. Inputs are decoded one at a time, as the
service calls the planner.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch
from transformers import EncoderDecoderModel, PreTrainedTokenizerBase

from models.onnx_runtime import export_graph, inference_session
from models.planner.beam_search import BeamSettings, Hypothesis, beam_search
from models.planner.engines import Candidate
from models.planner.onnx_graphs import DecoderStepGraph, EncoderGraph, decoder_shape
from models.planner.plan_vocab import PlanVocabulary


class OnnxPlanDecoder:
    """Plans from a ``minilm-encdec`` model (``onnx_graphs.graphs_support``) with its plan vocabulary."""

    def __init__(
        self,
        model: EncoderDecoderModel,
        tokenizer: PreTrainedTokenizerBase,
        vocab: PlanVocabulary,
        settings: BeamSettings,
        max_source_tokens: int,
        bias: dict[int, float],
        threads: int,
    ) -> None:
        self.tokenizer = tokenizer
        self.vocab = vocab
        self.settings = settings
        self.max_source_tokens = max_source_tokens
        self.shape = decoder_shape(model)
        assert self.shape.vocab_size == len(vocab), (
            f"the decoder writes {self.shape.vocab_size} words, the plan vocabulary has {len(vocab)}"
        )
        assert settings.max_new_tokens < self.shape.max_positions, (
            f"{settings.max_new_tokens} new tokens need more positions than the decoder's "
            f"{self.shape.max_positions}"
        )
        L, H, d = self.shape.layers, self.shape.heads, self.shape.head_dim
        self.cross_names = [f"cross_{kind}_{i}" for i in range(L) for kind in ("keys_t", "values")]
        self.past_names = [f"past_{kind}_{i}" for i in range(L) for kind in ("keys", "values")]
        present_names = [f"present_{kind}_{i}" for i in range(L) for kind in ("keys", "values")]
        S, T, B = 7, 3, 2  # example sizes; all three are dynamic in the graphs
        encoder_axes = {"input_ids": {1: "S"}} | {
            name: {3 if name.startswith("cross_keys") else 2: "S"} for name in self.cross_names
        }
        encoder = export_graph(
            EncoderGraph(model),
            {"input_ids": torch.ones(1, S, dtype=torch.long)},
            self.cross_names,
            encoder_axes,
        )
        step_example = {"tokens": torch.ones(B, dtype=torch.long), "position": torch.tensor([T])}
        step_axes: dict[str, dict[int, str]] = {"tokens": {0: "B"}, "log_probs": {0: "B"}}
        for i in range(L):
            for kind in ("keys", "values"):
                step_example[f"past_{kind}_{i}"] = torch.zeros(B, H, T, d)
                step_axes[f"past_{kind}_{i}"] = {0: "B", 2: "T"}
                step_axes[f"present_{kind}_{i}"] = {0: "B", 2: "T1"}
            step_example[f"cross_keys_t_{i}"] = torch.zeros(1, H, d, S)
            step_example[f"cross_values_{i}"] = torch.zeros(1, H, S, d)
            step_axes[f"cross_keys_t_{i}"] = {3: "S"}
            step_axes[f"cross_values_{i}"] = {2: "S"}
        step = export_graph(DecoderStepGraph(model), step_example, ["log_probs", *present_names], step_axes)
        self._encoder = inference_session(encoder, threads)
        self._step = inference_session(step, threads)
        self._masks: dict[tuple[int, ...], np.ndarray] = {}
        self.bias: np.ndarray | None = None
        if bias:
            self.bias = np.zeros(self.shape.vocab_size, dtype=np.float32)
            for token, value in bias.items():
                self.bias[token] = value

    def generate_texts(self, sources: Sequence[str]) -> list[str]:
        """The decoded plan of each source (inputs longer than the model allows keep their end)."""
        return [candidates[0].text for candidates in self.generate_candidates(sources)]

    def generate_candidates(self, sources: Sequence[str]) -> list[list[Candidate]]:
        """Each source's finished beams as decoded plans, best first."""
        self.tokenizer.truncation_side = "left"  # long dialogues keep their latest turns and the history
        found = []
        for source in sources:
            ids = self.tokenizer(source, truncation=True, max_length=self.max_source_tokens)["input_ids"]
            hypotheses = self.generate(np.array([ids], dtype=np.int64))
            found.append([Candidate(self.vocab.decode(words), score) for words, score in hypotheses])
        return found

    def generate(self, input_ids: np.ndarray) -> list[Hypothesis]:
        """Plan-word ids (start first) of the finished beams, best first, for one input's token ids
        int64 [1, S]."""
        feed = dict(zip(self.cross_names, self._encoder.run(None, {"input_ids": input_ids}), strict=True))
        empty = np.zeros(
            (self.settings.num_beams, self.shape.heads, 0, self.shape.head_dim), dtype=np.float32
        )
        past = [empty] * len(self.past_names)

        def step(tokens: np.ndarray, parents: np.ndarray) -> np.ndarray:
            nonlocal past
            position = past[0].shape[2]
            if position:  # beam b continues beam parents[b]: it takes that beam's keys and values
                past = [array[parents] for array in past]
            feed.update(zip(self.past_names, past, strict=True))
            feed.update(tokens=tokens, position=np.array([position]))
            log_probs, *past = self._step.run(None, feed)
            return log_probs

        return beam_search(step, self._allowed, self.bias, self.settings)

    def _allowed(self, generated: Sequence[int]) -> np.ndarray:
        """The grammar's additive mask after ``generated`` (a few states, each built once)."""
        allowed = tuple(self.vocab.allowed_next(generated))
        mask = self._masks.get(allowed)
        if mask is None:
            mask = np.full(self.shape.vocab_size, -np.inf, dtype=np.float32)
            mask[list(allowed)] = 0.0
            self._masks[allowed] = mask
        return mask
