"""Episode and benchmark metrics as TEACh's evaluation computes them, plus the failure histogram.

Per episode (TEACh ``evaluate_traj`` in alexa/teach ``src/teach/eval/compute_metrics.py``):
- SR: 1 when every goal condition holds at the end;
- GC: 1 - (final_total - final_satisfied) / (init_total - init_satisfied), i.e. the share of the
  conditions unsatisfied at the start that the agent completed (for EDH the start is after the history;
  for TfD it is the game's start), satisfied counts capped at totals;
- trajectory-length weighted SR and GC (TEACh's ``success_spl``/``goal_condition_spl``, the JARVIS seed's
  eq. (4) with m = SR or GC): m * |A_R| / max(|A_R|, |Â|), where |A_R| is the reference length and |Â|
  the agent's.
Over a split (TEACh ``aggregate_metrics``): SR is the share of successes; GC is completed over total goal
conditions summed over episodes; weighted metrics are averages with weights |A_R| / sum |A_R|. Field
names are TEACh's, so our result files read like theirs. Where TEACh would divide by zero we return
documented values instead (see ``episode_metrics`` and ``aggregate``).

The failure histogram is the JARVIS seed's Table 8: each failure reason's share of all failed actions.
"""

from __future__ import annotations

from collections import Counter, defaultdict
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from statistics import fmean
from typing import Any

from symbolic.thor import MAX_FAILED_ACTIONS, MAX_STEPS


@dataclass(frozen=True)
class EpisodeOutcome:
    """What one evaluated episode produced; everything the metrics need."""

    instance_id: str
    task_name: str
    success: bool
    gc_satisfied: int
    """Goal conditions satisfied in the final state."""
    gc_total: int
    """Goal conditions in the final state."""
    init_gc_satisfied: int
    """Goal conditions satisfied when the agent took over (EDH: after the history; TfD: at the start)."""
    init_gc_total: int
    pred_len: int
    """|Â|: actions the agent returned (TEACh's traj_len, failed ones included)."""
    ref_len: int
    """|A_R|: actions of the reference trajectory (TEACh: len(driver_actions_future))."""
    failure_reasons: Mapping[str, int] = field(default_factory=dict)
    """Failed actions by reason (harness.sim.failures.FailureReason values)."""
    steps: int = 0
    """Step requests served to the agent in this episode."""
    wall_s: float = 0.0
    """Wall-clock seconds the episode took."""
    predicted_stop: bool = False
    """The agent ended the episode itself with Stop."""
    error: bool = False
    """The episode ended on an error (the agent service failed), as TEACh counts them."""

    @property
    def num_failed_actions(self) -> int:
        return sum(self.failure_reasons.values())


def _remaining(total: int, satisfied: int) -> int:
    """Unsatisfied goal conditions, with satisfied capped at the total as TEACh caps it."""
    return total - min(total, satisfied)


def goal_condition_success(outcome: EpisodeOutcome) -> float:
    """GC = 1 - final unsatisfied / initially unsatisfied (TEACh; negative if the agent undid work).

    With nothing unsatisfied at the start (TEACh would divide by zero): 1.0 if nothing is unsatisfied at
    the end either, else 0.0.
    """
    remaining_init = _remaining(outcome.init_gc_total, outcome.init_gc_satisfied)
    remaining_final = _remaining(outcome.gc_total, outcome.gc_satisfied)
    if remaining_init == 0:
        return 1.0 if remaining_final == 0 else 0.0
    return 1.0 - remaining_final / remaining_init


def length_weight(outcome: EpisodeOutcome) -> float:
    """min(1, |A_R| / max(|A_R|, |Â|)) (JARVIS eq. 4); 1.0 when both lengths are 0."""
    longest = max(outcome.ref_len, outcome.pred_len)
    return min(1.0, outcome.ref_len / longest) if longest > 0 else 1.0


def episode_metrics(outcome: EpisodeOutcome) -> dict[str, Any]:
    """TEACh's per-trajectory metrics: success (SR), goal_condition_success (GC), success_spl (TLW-SR),
    goal_condition_spl (TLW-GC), their path-length-weighted numerators, and the counts behind them."""
    gc = goal_condition_success(outcome)
    weight = length_weight(outcome)
    tlw_sr = float(outcome.success) * weight
    tlw_gc = gc * weight
    remaining_init = _remaining(outcome.init_gc_total, outcome.init_gc_satisfied)
    return {
        "instance_id": outcome.instance_id,
        "task_name": outcome.task_name,
        "success": int(outcome.success),
        "completed_goal_conditions": remaining_init - _remaining(outcome.gc_total, outcome.gc_satisfied),
        "total_goal_conditions": remaining_init,
        "goal_condition_success": gc,
        "success_spl": tlw_sr,
        "path_len_weighted_success_spl": tlw_sr * outcome.ref_len,
        "goal_condition_spl": tlw_gc,
        "path_len_weighted_goal_condition_spl": tlw_gc * outcome.ref_len,
        "path_len_weight": outcome.ref_len,
        "gt_path_len": outcome.ref_len,
        "traj_len": outcome.pred_len,
        "predicted_stop": int(outcome.predicted_stop),
        "num_api_fails": outcome.num_failed_actions,
        "error": int(outcome.error),
        "steps": outcome.steps,
        "wall_s": outcome.wall_s,
        "failure_reasons": dict(outcome.failure_reasons),
    }


def failure_counts(outcomes: Iterable[EpisodeOutcome]) -> Counter[str]:
    """Failed actions by reason over all episodes."""
    counts: Counter[str] = Counter()
    for outcome in outcomes:
        counts.update(dict(outcome.failure_reasons))
    return counts


def failure_histogram(outcomes: Iterable[EpisodeOutcome]) -> dict[str, float]:
    """Each failure reason's percentage of all failed actions, most frequent first (JARVIS Table 8)."""
    counts = failure_counts(outcomes)
    total = sum(counts.values())
    return {reason: 100.0 * n / total for reason, n in counts.most_common() if n > 0}


def _summary(per_episode: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """TEACh's aggregate_metrics result table over some episodes' metrics."""
    n = len(per_episode)
    num_successes = sum(m["success"] for m in per_episode)
    completed = sum(m["completed_goal_conditions"] for m in per_episode)
    total = sum(m["total_goal_conditions"] for m in per_episode)
    total_weight = sum(m["gt_path_len"] for m in per_episode)
    if total_weight > 0:
        plw_sr = sum(m["path_len_weighted_success_spl"] for m in per_episode) / total_weight
        plw_gc = sum(m["path_len_weighted_goal_condition_spl"] for m in per_episode) / total_weight
    else:
        plw_sr = plw_gc = 0.0
    return {
        "success": {"num_successes": num_successes, "num_evals": n, "success_rate": num_successes / n},
        "goal_condition_success": {
            "completed_goal_conditions": completed,
            "total_goal_conditions": total,
            "goal_condition_success_rate": completed / total if total > 0 else 0.0,
            "mean_goal_condition_success": fmean(m["goal_condition_success"] for m in per_episode),
        },
        "path_length_weighted_success_rate": plw_sr,
        "path_length_weighted_goal_condition_success_rate": plw_gc,
        "num_predicted_stops": sum(m["predicted_stop"] for m in per_episode),
        "num_fails_by_api_limit": sum(m["num_api_fails"] >= MAX_FAILED_ACTIONS for m in per_episode),
        "num_fails_by_traj_len_limit": sum(m["traj_len"] >= MAX_STEPS for m in per_episode),
        "num_fails_by_error": sum(m["error"] for m in per_episode),
        "n": n,
        "mean_steps": fmean(m["steps"] for m in per_episode),
        "mean_wall_s": fmean(m["wall_s"] for m in per_episode),
    }


def aggregate(outcomes: Sequence[EpisodeOutcome]) -> dict[str, Any]:
    """A split's summary in TEACh's metrics-file layout, per task type too, with the failure histogram.

    ``goal_condition_success_rate`` is TEACh's (completed over total conditions, summed over episodes; 0.0
    when there were none); ``mean_goal_condition_success`` is the per-episode mean the JARVIS seed
    describes. Raises ValueError for no outcomes (every rate would be 0/0).
    """
    if not outcomes:
        raise ValueError("aggregate() needs at least one EpisodeOutcome")
    per_episode = [episode_metrics(o) for o in outcomes]
    by_task: defaultdict[str, list[Mapping[str, Any]]] = defaultdict(list)
    for metrics in per_episode:
        by_task[metrics["task_name"]].append(metrics)
    return {
        **_summary(per_episode),
        "per_task": {name: _summary(group) for name, group in sorted(by_task.items())},
        "failure_histogram": failure_histogram(outcomes),
        "failure_counts": dict(failure_counts(outcomes).most_common()),
    }
