"""Beam search for one input, by the rules of ``transformers``' ``generate`` (v5 ``_beam_search``).

Why a copy: ``generate`` runs these few rules through general machinery (logits processors, stopping
criteria, batched bookkeeping in ~40 tensor operations a step) that cost about half as much as the decoder
step it drives. For one input the rules are: the log-probabilities plus the sequence bias plus the
grammar's mask (``-inf`` off the allowed tokens), added to each beam's score; keep the ``2 x beams`` best
continuations of all beams; the best ``beams`` of them that did not just end run on; those that ended
among the best ``beams`` enter the finished list with their score divided by their generated length
(``length_penalty`` 1); with ``early_stopping=True`` the search stops once ``beams`` hypotheses have
finished, when no running beam can beat the worst finished one, or at the length limit. Scores are float32
with transformers' ``-1e9`` for "impossible", as there, so the same log-probabilities give the same plan.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

NEG = np.float32(-1.0e9)  # transformers' "impossible" score: finite, so finished and empty slots still sort
ZERO = np.float32(0.0)


@dataclass(frozen=True)
class BeamSettings:
    """What ``generate`` was given: ``num_beams``, the start and end ids and ``max_new_tokens``, with length
    penalty 1 and ``early_stopping=True`` (as ``SubgoalGenerator`` calls it)."""

    num_beams: int
    start_id: int
    end_id: int
    max_new_tokens: int


Step = Callable[[np.ndarray, np.ndarray], np.ndarray]
"""(last token of each beam int64 [beams], the beam each continues int64 [beams]) -> log-probabilities of
the next token float32 [beams, V]. The step reorders its own cache by the second argument first."""

Allowed = Callable[[Sequence[int]], np.ndarray]
"""A running beam's tokens (start id first) -> float32 [V], 0 on the tokens the grammar allows next and
``-inf`` elsewhere."""


def _top(scores: np.ndarray, k: int) -> np.ndarray:
    """Indices of the ``k`` highest scores, highest first (of equal scores, the lower index first)."""
    return np.argsort(-scores, kind="stable")[:k]


Hypothesis = tuple[list[int], float]
"""A finished sequence (the start id, the generated ids, the end id unless cut by the limit) and its score:
the summed log-probability over the generated length, as transformers' ``sequences_scores``."""


def beam_search(
    step: Step, allowed: Allowed, bias: np.ndarray | None, settings: BeamSettings
) -> list[Hypothesis]:
    """The finished hypotheses, best first (at most ``num_beams``; what ``num_return_sequences`` returns):
    the first is ``generate``'s answer, the others what the planner falls back on (``ModelPlanner``)."""
    K = settings.num_beams
    max_length = 1 + settings.max_new_tokens  # the start token is the decoder's prompt
    running = [[settings.start_id] for _ in range(K)]
    running_scores = np.full(K, NEG)
    running_scores[0] = ZERO  # only the first beam is live at the start: no K copies of one continuation
    finished = [[settings.start_id] for _ in range(K)]
    finished_scores = np.full(K, NEG)
    finished_flags = np.zeros(K, dtype=bool)
    top_half = np.arange(2 * K) < K  # only the best K continuations may finish
    parents = np.arange(K)
    improvable = True
    length = 1
    while True:
        log_probs = step(np.array([beam[-1] for beam in running]), parents)  # [K, V]
        V = log_probs.shape[1]
        if bias is not None:
            log_probs = log_probs + bias
        log_probs = log_probs + np.stack([allowed(beam) for beam in running])
        total = (log_probs + running_scores[:, None]).reshape(-1)  # [K * V]
        top_index = _top(total, 2 * K)
        top_scores = total[top_index]
        top_parents, top_tokens = np.divmod(top_index, V)
        candidates = [
            running[p] + [t] for p, t in zip(top_parents.tolist(), top_tokens.tolist(), strict=True)
        ]
        ended = (top_tokens == settings.end_id) | (length + 1 >= max_length)

        live_scores = top_scores + np.where(ended, NEG, ZERO)
        keep = _top(live_scores, K)
        running = [candidates[i] for i in keep]
        running_scores, parents = live_scores[keep], top_parents[keep]

        just_finished = ended & top_half
        scores = top_scores / np.float32(length)  # the generated length, to the power 1
        if finished_flags.all():  # K hypotheses finished: no more
            scores = scores + NEG
        if not improvable:
            scores = scores + NEG
        scores = scores + np.where(just_finished, ZERO, NEG)
        merged_scores = np.concatenate((finished_scores, scores))
        best = _top(merged_scores, K)
        merged = finished + candidates
        finished = [merged[i] for i in best]
        finished_scores = merged_scores[best]
        finished_flags = np.concatenate((finished_flags, just_finished))[best]

        length += 1
        best_running = running_scores[0] / np.float32(length - 1)
        worst_finished = np.where(finished_flags, finished_scores.min(), NEG)
        improvable = improvable and bool((best_running > worst_finished).any())
        if not improvable or finished_flags.all() or ended.all():
            kept = [i for i in range(K) if finished_flags[i]] or [0]
            return [(finished[i], float(finished_scores[i])) for i in kept]
