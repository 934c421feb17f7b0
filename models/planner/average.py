"""Average the weights of planner checkpoints that share one starting point (a "model soup").

A second schedule on one domain (ALFRED sentences only, say) gains there and forgets some of the other;
interpolating its weights with the checkpoint it started from keeps most of both (Wortsman et al.,
"Robust fine-tuning of zero-shot models", CVPR 2022). That only works between runs of one lineage, so
every checkpoint must have the same parameters, shapes, tokenizer and plan vocabulary; anything else is
refused before a file is written.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import torch

from models.planner.modeling import PlannerModel, load_planner_model, read_planner_meta, save_planner_model


class IncompatibleCheckpoints(ValueError):
    """The checkpoints cannot be averaged: another architecture, tokenizer or plan vocabulary."""


def _check_weights(weights: Sequence[float], count: int) -> list[float]:
    if len(weights) != count:
        raise ValueError(f"{count} checkpoints need {count} weights, got {len(weights)}")
    if any(not math.isfinite(w) or w < 0 for w in weights):
        raise ValueError(f"weights must be finite and non-negative, got {list(weights)}")
    total = sum(weights)
    if total <= 0:
        raise ValueError("the weights must not all be zero")
    return [w / total for w in weights]


def _check_compatible(first: PlannerModel, other: PlannerModel) -> None:
    name = other.path
    if first.tokenizer.get_vocab() != other.tokenizer.get_vocab():
        raise IncompatibleCheckpoints(f"{name}: another tokenizer than {first.path}")
    first_plan = first.plan_vocab.words if first.plan_vocab is not None else None
    other_plan = other.plan_vocab.words if other.plan_vocab is not None else None
    if first_plan != other_plan:
        raise IncompatibleCheckpoints(f"{name}: another plan vocabulary than {first.path}")
    mine, theirs = first.model.state_dict(), other.model.state_dict()
    if mine.keys() != theirs.keys():
        missing = sorted(set(mine) ^ set(theirs))[:3]
        raise IncompatibleCheckpoints(f"{name}: other parameters than {first.path} (e.g. {missing})")
    for key, tensor in mine.items():
        if tensor.shape != theirs[key].shape:
            raise IncompatibleCheckpoints(
                f"{name}: {key} is {tuple(theirs[key].shape)}, {tuple(tensor.shape)} in {first.path}"
            )


def average_checkpoints(
    paths: Sequence[Path], weights: Sequence[float], out: Path, half_precision: bool = True
) -> PlannerModel:
    """Write ``sum(w_i * theta_i)`` (weights normalised to sum 1) to ``out`` and return it loaded.

    The first checkpoint gives the configs, tokenizer and metadata (its calibrated Navigate bias too,
    until ``calibrate --write`` chooses one for the average); ``averaged_from`` records each part.
    """
    if not paths:
        raise ValueError("nothing to average: give at least one checkpoint")
    shares = _check_weights(weights, len(paths))
    planners = [load_planner_model(Path(p)) for p in paths]
    for other in planners[1:]:
        _check_compatible(planners[0], other)
    base = planners[0]
    states = [p.model.state_dict() for p in planners]
    averaged: dict[str, torch.Tensor] = {}
    for key, tensor in states[0].items():
        if tensor.is_floating_point():
            averaged[key] = sum(
                (share * state[key].double() for share, state in zip(shares, states, strict=True)),
                torch.zeros_like(tensor, dtype=torch.float64),
            ).to(tensor.dtype)
        else:
            averaged[key] = tensor
    base.model.load_state_dict(averaged)
    meta = {
        **read_planner_meta(Path(paths[0])),
        "dev_loss": None,  # the parts' losses say nothing about the average's
        "averaged_from": [
            {"checkpoint": str(path), "weight": share, "step": read_planner_meta(Path(path)).get("step")}
            for path, share in zip(paths, shares, strict=True)
        ],
    }
    save_planner_model(base, out, meta, half_precision=half_precision)
    return load_planner_model(out)
