"""Calibrate the decoder's Navigate bias on evaluation sets held out from reporting, and record it.

Reference plans write ``Navigate X`` wherever the expert walked before acting on X, and the words seldom say
whether it had to walk; a beam of 4 then prefers the plan without the step. A logit added to the Navigate
word (``GenerationConfig.navigate_bias``) moves that decision. It is a decoding hyperparameter, so it is
chosen on a set the reported metrics do not use (the generator's valid_seen games, not valid_unseen) and
written into the checkpoint's planner_meta.json, where ``SubgoalGenerator`` reads it, and into its
generation_config.json, where a bare ``generate`` reads it (``hub.py``).
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from transformers import AutoConfig

from models.planner.config import GenerationConfig
from models.planner.data import PlannerExample
from models.planner.evaluate import predict_in_batches, score_plans
from models.planner.hub import write_generation_defaults
from models.planner.modeling import PLANNER_META_FILE, PlannerModel
from models.planner.plan_vocab import PlanVocabulary
from models.planner.predict import NAVIGATE_BIAS_KEY, SubgoalGenerator
from symbolic.ontology import Ontology
from symbolic.subgoals import parse_subgoals


@dataclass(frozen=True)
class BiasScore:
    """Exact match of every set at one bias, and their mean weighted by set size."""

    bias: float
    exact_match: dict[str, float]
    pooled: float


def score_biases(
    planner: PlannerModel,
    ontology: Ontology,
    sets: Mapping[str, Sequence[PlannerExample]],
    biases: Sequence[float],
    num_beams: int = GenerationConfig.num_beams,
    batch_size: int = 32,
) -> list[BiasScore]:
    """Whole-plan exact match of every set at every bias (one loaded model, decoded once per bias)."""
    scores = []
    for bias in biases:
        config = GenerationConfig(num_beams=num_beams, navigate_bias=bias)
        generator = SubgoalGenerator(planner, ontology, config)
        matched, total, per_set = 0, 0, {}
        for name, examples in sets.items():
            predictions = predict_in_batches(
                generator.predict_many, examples, batch_size, description=f"{name} bias {bias:g}"
            )
            references = [parse_subgoals(example.target, ontology) for example in examples]
            exact = score_plans([list(p.subgoals) for p in predictions], references).exact_match
            per_set[name] = exact
            matched, total = matched + round(exact * len(examples)), total + len(examples)
        scores.append(BiasScore(bias, per_set, matched / max(total, 1)))
    return scores


def best_bias(scores: Sequence[BiasScore]) -> BiasScore:
    """The highest pooled exact match; of equals, the bias nearest 0 (decode as trained when it costs
    nothing)."""
    if not scores:
        raise ValueError("no biases were scored")
    return max(scores, key=lambda s: (s.pooled, -abs(s.bias)))


def record_bias(checkpoint: Path, scores: Sequence[BiasScore], calibrated_on: Sequence[str]) -> BiasScore:
    """Write the best of ``scores`` and every score it was chosen from into the checkpoint's
    planner_meta.json, and the best into its generation defaults; returns the best."""
    chosen = best_bias(scores)
    path = checkpoint / PLANNER_META_FILE
    meta = json.loads(path.read_text(encoding="utf-8")) if path.is_file() else {}
    meta[NAVIGATE_BIAS_KEY] = chosen.bias
    meta["navigate_bias_calibration"] = {
        "sets": list(calibrated_on),
        "exact_match": chosen.exact_match,
        "pooled_exact_match": chosen.pooled,
        "pooled_exact_match_by_bias": {f"{s.bias:g}": s.pooled for s in scores},
    }
    path.write_text(json.dumps(meta, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    config = AutoConfig.from_pretrained(str(checkpoint))
    write_generation_defaults(checkpoint, config, PlanVocabulary.load(checkpoint), chosen.bias)
    return chosen
