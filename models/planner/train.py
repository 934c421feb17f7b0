"""Train a planner recipe on a dataset folder, with a progress bar, resumable from its last checkpoint.

The objective is the seed's (Sec. 3): cross entropy between the generated and the reference future
subgoal sequence, here with label smoothing. A run folder holds ``last/`` (fp32 weights, tokenizer,
``planner_meta.json`` with the step, and ``optimizer.pt`` with the optimizer, schedule and RNG states,
which is never part of an exported checkpoint) and, when the run finishes, ``final/`` (fp16 weights when
``export_fp16``). Running the same command again continues from ``last/`` at the step it reached.
"""

from __future__ import annotations

import logging
import math
import random
import shutil
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import torch
from torch.nn import functional as F
from tqdm import tqdm

from models.planner.config import Recipe, TrainConfig
from models.planner.data import DatasetFiles, PlannerExample, file_fingerprint, read_examples
from models.planner.modeling import (
    PlannerModel,
    add_missing_marks,
    build_bart_scratch,
    build_minilm_encdec,
    count_parameters,
    encoder_positions,
    freeze_pretrained_word_embeddings,
    load_planner_model,
    no_decay_parameters,
    read_planner_meta,
    save_planner_model,
)
from models.planner.plan_vocab import PlanVocabulary
from models.planner.text import PLANNER_MARKS
from models.planner.tokenizer import end_of_target_id, pruned_minilm_tokenizer, train_bpe_tokenizer
from symbolic.ontology import load_ontology

LOG = logging.getLogger(__name__)

OPTIMIZER_FILE = "optimizer.pt"
DEV_LOSS_EXAMPLES = 1500  # dev examples scored at each evaluation; enough for a stable mean
SORT_WINDOW_BATCHES = 50  # batches per window sorted by length, so batches pad little but stay shuffled


@dataclass(frozen=True)
class EncodedExample:
    source_ids: list[int]
    target_ids: list[int]
    """Target tokens ending with the end-of-plan id; no start token (the decoder's start id is prepended)."""


@dataclass(frozen=True)
class TrainResult:
    run_dir: Path
    step: int
    finished: bool
    last_train_loss: float
    dev_loss: float | None


class ResumeMismatch(ValueError):
    """``last/`` was trained with another recipe, config or dataset; the message names the difference."""


def encode(
    planner: PlannerModel, examples: Sequence[PlannerExample], config: TrainConfig
) -> list[EncodedExample]:
    """Token ids of sources (cut from the left: the latest turns and the history matter most) and targets
    (plan words when the decoder has a plan vocabulary, else tokenizer pieces), each ending its plan."""
    tokenizer = planner.tokenizer
    tokenizer.truncation_side = "left"
    sources = tokenizer(
        [e.source for e in examples], truncation=True, max_length=config.max_source_tokens
    ).input_ids
    if planner.plan_vocab is not None:
        ontology = load_ontology()
        vocab = planner.plan_vocab
        plans = [vocab.encode(e.target, ontology) for e in examples]
        return [
            EncodedExample(list(source), plan[: config.max_target_tokens - 1] + [vocab.end_id])
            if len(plan) > config.max_target_tokens
            else EncodedExample(list(source), plan)
            for source, plan in zip(sources, plans, strict=True)
        ]
    targets = tokenizer([e.target for e in examples], add_special_tokens=False).input_ids
    end = end_of_target_id(tokenizer)
    return [
        EncodedExample(list(source), list(target[: config.max_target_tokens - 1]) + [end])
        for source, target in zip(sources, targets, strict=True)
    ]


def epoch_batches(lengths: Sequence[int], batch_size: int, seed: int, epoch: int) -> list[list[int]]:
    """The batches of one epoch, a pure function of (seed, epoch) so a resumed run sees the same order.

    Indices are shuffled, sorted by length inside windows of ``SORT_WINDOW_BATCHES`` batches (less
    padding), cut into batches, and the batches shuffled again.
    """
    rng = random.Random(f"{seed}:{epoch}")
    order = list(range(len(lengths)))
    rng.shuffle(order)
    window = batch_size * SORT_WINDOW_BATCHES
    batches: list[list[int]] = []
    for start in range(0, len(order), window):
        chunk = sorted(order[start : start + window], key=lambda i: lengths[i])
        batches += [chunk[i : i + batch_size] for i in range(0, len(chunk), batch_size)]
    rng.shuffle(batches)
    return batches


def collate(batch: Sequence[EncodedExample], pad_id: int, start_id: int) -> dict[str, torch.Tensor]:
    """Padded tensors: input_ids/attention_mask [B, S]; decoder_input_ids and labels [B, T] (-100 = pad)."""
    B = len(batch)
    S = max(len(e.source_ids) for e in batch)
    T = max(len(e.target_ids) for e in batch)
    input_ids = torch.full((B, S), pad_id, dtype=torch.long)
    attention_mask = torch.zeros((B, S), dtype=torch.long)
    labels = torch.full((B, T), -100, dtype=torch.long)
    decoder_input_ids = torch.full((B, T), pad_id, dtype=torch.long)
    for row, example in enumerate(batch):
        s, t = len(example.source_ids), len(example.target_ids)
        input_ids[row, :s] = torch.tensor(example.source_ids)
        attention_mask[row, :s] = 1
        labels[row, :t] = torch.tensor(example.target_ids)
        decoder_input_ids[row, 0] = start_id
        decoder_input_ids[row, 1:t] = torch.tensor(example.target_ids[:-1])
    return {
        "input_ids": input_ids,
        "attention_mask": attention_mask,
        "decoder_input_ids": decoder_input_ids,
        "labels": labels,
    }


def sequence_loss(model: torch.nn.Module, batch: dict[str, torch.Tensor], smoothing: float) -> torch.Tensor:
    """Mean token cross entropy of the reference plan given the input (teacher forcing)."""
    logits = model(
        input_ids=batch["input_ids"],
        attention_mask=batch["attention_mask"],
        decoder_input_ids=batch["decoder_input_ids"],
    ).logits  # [B, T, V]
    V = logits.shape[-1]
    return F.cross_entropy(
        logits.reshape(-1, V), batch["labels"].reshape(-1), ignore_index=-100, label_smoothing=smoothing
    )


def learning_rate_factor(step: int, config: TrainConfig) -> float:
    """Linear warm-up to the peak, then linear decay to zero at ``max_steps``."""
    if step < config.warmup_steps:
        return (step + 1) / config.warmup_steps
    remaining = config.max_steps - step
    return max(0.0, remaining / max(1, config.max_steps - config.warmup_steps))


def _start_id(planner: PlannerModel) -> int:
    start = planner.model.generation_config.decoder_start_token_id
    if start is None:
        start = planner.model.config.decoder_start_token_id
    if start is None:
        raise ValueError("the model config names no decoder_start_token_id")
    return int(start)


def _pad_id(planner: PlannerModel) -> int:
    pad = planner.tokenizer.pad_token_id
    if pad is None:
        raise ValueError(f"{type(planner.tokenizer).__name__} has no pad token")
    return int(pad)


def build_planner(recipe: Recipe, train_examples: Sequence[PlannerExample]) -> PlannerModel:
    """A fresh model of the recipe; ``bart-scratch`` first trains its tokenizer on the training texts."""
    torch.manual_seed(recipe.train.seed)
    if recipe.name == "bart-scratch":
        texts = (text for example in train_examples for text in (example.source, example.target))
        bpe = train_bpe_tokenizer(texts, recipe.bart.vocab_size)
        return PlannerModel(build_bart_scratch(recipe.bart, bpe), bpe)
    arch = recipe.minilm_decoder
    wordpiece, kept = pruned_minilm_tokenizer((e.source for e in train_examples), arch.keep_first_tokens)
    vocab = PlanVocabulary.from_ontology(load_ontology())
    return PlannerModel(build_minilm_encdec(arch, wordpiece, kept, vocab), wordpiece, plan_vocab=vocab)


def make_optimizer(planner: PlannerModel, recipe: Recipe) -> torch.optim.Optimizer:
    """AdamW; with the MiniLM recipe's frozen pretrained word embeddings, those rows get no gradient
    (only the planner marks' rows learn) and the matrix no weight decay."""
    model, config = planner.model, recipe.train
    if recipe.name == "minilm-encdec" and recipe.minilm_decoder.freeze_word_embeddings:
        marks = planner.tokenizer.convert_tokens_to_ids(list(PLANNER_MARKS))
        assert isinstance(marks, list), "a list of tokens gives a list of ids"
        freeze_pretrained_word_embeddings(model, trainable_from=min(marks))
    exempt = no_decay_parameters(model)
    decayed = [p for p in model.parameters() if id(p) not in exempt]
    plain = [p for p in model.parameters() if id(p) in exempt]
    return torch.optim.AdamW(
        [{"params": decayed, "weight_decay": config.weight_decay}, {"params": plain, "weight_decay": 0.0}],
        lr=config.learning_rate,
    )


def dev_loss(planner: PlannerModel, encoded: Sequence[EncodedExample], batch_size: int) -> float:
    """Token cross entropy (no smoothing) on the dev examples, averaged over batches."""
    planner.model.eval()
    pad, start = _pad_id(planner), _start_id(planner)
    losses = []
    order = sorted(range(len(encoded)), key=lambda i: len(encoded[i].source_ids))
    with torch.no_grad():
        for i in range(0, len(order), batch_size):
            batch = collate([encoded[j] for j in order[i : i + batch_size]], pad, start)
            losses.append(float(sequence_loss(planner.model, batch, 0.0)))
    planner.model.train()
    return sum(losses) / max(1, len(losses))


def _save_last(
    run_dir: Path,
    planner: PlannerModel,
    optimizer: torch.optim.Optimizer,
    meta: dict[str, object],
) -> None:
    """Write ``last/`` beside the old one, then swap by renames: a run killed while saving still resumes."""
    staging = run_dir / "last.tmp"
    shutil.rmtree(staging, ignore_errors=True)
    save_planner_model(planner, staging, meta)
    torch.save(
        {"optimizer": optimizer.state_dict(), "torch_rng": torch.get_rng_state()}, staging / OPTIMIZER_FILE
    )
    last, previous = run_dir / "last", run_dir / "last.old"
    if last.exists():
        last.rename(previous)
    staging.rename(last)
    shutil.rmtree(previous, ignore_errors=True)


def _recover_interrupted_save(run_dir: Path) -> None:
    """A run killed between the two renames of ``_save_last`` left its checkpoint in ``last.old``."""
    last, previous = run_dir / "last", run_dir / "last.old"
    if previous.is_dir() and not last.exists():
        previous.rename(last)


RESUME_FREE_FIELDS = frozenset({"num_threads", "save_every", "eval_every"})
"""TrainConfig fields a resumed run may change: they set speed and bookkeeping, not what is learned (a run
started on two threads may go on with one while another job has the other core)."""


def _check_resume(meta: dict[str, object], recipe: Recipe, fingerprint: str) -> None:
    saved = meta.get("train_config")
    problems = []
    if meta.get("recipe") != recipe.name:
        problems.append(f"recipe {meta.get('recipe')!r} != {recipe.name!r}")
    if isinstance(saved, dict):
        wanted = asdict(recipe.train)
        problems += [
            f"{k}: saved {saved.get(k)!r}, asked {v!r}"
            for k, v in wanted.items()
            if k not in RESUME_FREE_FIELDS and saved.get(k) != v
        ]
    if meta.get("data_fingerprint") != fingerprint:
        problems.append("the training file changed since the run started")
    if problems:
        raise ResumeMismatch(
            "cannot resume: " + "; ".join(problems) + ". Use a new run folder or delete its last/."
        )


def _check_source_length(planner: PlannerModel, config: TrainConfig) -> None:
    """Fail before the first step, not inside it, when inputs could outrun the position table."""
    positions = encoder_positions(planner.model)
    if positions is not None and config.max_source_tokens > positions:
        raise ValueError(
            f"max_source_tokens {config.max_source_tokens} exceeds the encoder's {positions} positions"
        )


def train(
    recipe: Recipe,
    dataset: DatasetFiles,
    run_dir: Path,
    stop_at_step: int | None = None,
    export_fp16: bool = True,
    show_progress: bool = True,
    init_from: Path | None = None,
) -> TrainResult:
    """Train (or resume) ``recipe`` on ``dataset`` into ``run_dir``; stops early at ``stop_at_step``.

    ``init_from`` starts a new run from another run's weights and tokenizer (a second, longer schedule
    after a first one ended) instead of from scratch, with any planner mark it lacks added
    (``add_missing_marks``); a run that already has ``last/`` resumes as usual.

    Deterministic given ``recipe.train.seed``: the batch order is a function of (seed, epoch) and the RNG
    state travels with the checkpoint.
    """
    config = recipe.train
    torch.set_num_threads(config.num_threads)
    run_dir.mkdir(parents=True, exist_ok=True)
    train_examples = read_examples(dataset.train)
    fingerprint = file_fingerprint(dataset.train)
    _recover_interrupted_save(run_dir)
    last = run_dir / "last"
    step = 0
    history: list[dict[str, float]] = []
    if (last / "planner_meta.json").is_file():
        meta = read_planner_meta(last)
        _check_resume(meta, recipe, fingerprint)
        planner = load_planner_model(last)
        step = int(str(meta["step"]))
        saved_history = meta.get("history")
        history = list(saved_history) if isinstance(saved_history, list) else []
        LOG.info("resuming %s from step %d", run_dir, step)
    elif init_from is not None:
        planner = load_planner_model(init_from)
        added = add_missing_marks(planner)
        if added:
            LOG.info("%s was trained before the marks %s; they start as <COM>", init_from, added)
    else:
        planner = build_planner(recipe, train_examples)
    _check_source_length(planner, config)
    model = planner.model
    model.train()
    optimizer = make_optimizer(planner, recipe)
    if step > 0:
        state = torch.load(last / OPTIMIZER_FILE, weights_only=False)
        optimizer.load_state_dict(state["optimizer"])
        torch.set_rng_state(state["torch_rng"])
    scheduler = torch.optim.lr_scheduler.LambdaLR(
        optimizer, lambda s: learning_rate_factor(s, config), last_epoch=step - 1
    )

    encoded = encode(planner, train_examples, config)
    dev_examples = read_examples(dataset.dev) if dataset.dev.is_file() else []
    dev_encoded = encode(planner, dev_examples[:DEV_LOSS_EXAMPLES], config) if dev_examples else []
    lengths = [len(e.source_ids) + len(e.target_ids) for e in encoded]
    steps_per_epoch = math.ceil(len(encoded) / config.batch_size)
    pad, start = _pad_id(planner), _start_id(planner)

    def meta_now(current_dev: float | None) -> dict[str, object]:
        return {
            "recipe": recipe.name,
            "train_config": asdict(config),
            "architecture": asdict(recipe.bart if recipe.name == "bart-scratch" else recipe.minilm_decoder),
            "data_fingerprint": fingerprint,
            "train_examples": len(encoded),
            "step": step,
            "parameters": count_parameters(model),
            "dev_loss": current_dev,
            "history": history,
            "initialised_from": str(init_from) if init_from is not None else None,
        }

    target = config.max_steps if stop_at_step is None else min(stop_at_step, config.max_steps)
    bar = tqdm(total=config.max_steps, initial=step, desc=f"train {recipe.name}", disable=not show_progress)
    running, current_dev = float("nan"), None
    started = time.monotonic()
    while step < target:
        epoch, offset = divmod(step, steps_per_epoch)
        batches = epoch_batches(lengths, config.batch_size, config.seed, epoch)
        for indices in batches[offset:]:
            if step >= target:
                break
            loss = sequence_loss(
                model, collate([encoded[i] for i in indices], pad, start), config.label_smoothing
            )
            optimizer.zero_grad(set_to_none=True)
            loss.backward()
            torch.nn.utils.clip_grad_norm_(model.parameters(), 1.0)
            optimizer.step()
            scheduler.step()
            step += 1
            value = float(loss.detach())
            running = value if math.isnan(running) else 0.98 * running + 0.02 * value
            bar.update(1)
            bar.set_postfix(loss=f"{running:.3f}", epoch=epoch)
            if config.eval_every and dev_encoded and step % config.eval_every == 0:
                current_dev = dev_loss(planner, dev_encoded, config.batch_size)
                history.append(
                    {
                        "step": step,
                        "train_loss": running,
                        "dev_loss": current_dev,
                        "minutes": (time.monotonic() - started) / 60,
                    }
                )
                LOG.info("step %d: train loss %.4f, dev loss %.4f", step, running, current_dev)
            if step % config.save_every == 0 or step == target:
                _save_last(run_dir, planner, optimizer, meta_now(current_dev))
    bar.close()
    finished = step >= config.max_steps
    if finished:
        if dev_encoded:
            current_dev = dev_loss(planner, dev_encoded, config.batch_size)
        final_meta = meta_now(current_dev)
        _save_last(run_dir, planner, optimizer, final_meta)
        save_planner_model(planner, run_dir / "final", final_meta, half_precision=export_fp16)
    return TrainResult(
        run_dir=run_dir, step=step, finished=finished, last_train_loss=running, dev_loss=current_dev
    )
