"""Make a trained run the default checkpoint: copy its fp16 weights, its evaluation and a model card.

DESIGN.md §7: every default checkpoint has a model card saying its data, the command that made it, its
metrics and its size. The card is written from the run's ``planner_meta.json`` and the JSON that
``python -m models.planner evaluate --out`` wrote, so the numbers it quotes are the measured ones.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from models.planner.evaluate import format_miss_table, format_report_table
from models.planner.modeling import PLANNER_META_FILE, read_planner_meta
from models.planner.plan_vocab import PLAN_VOCAB_FILE

CHECKPOINT_FILES: tuple[str, ...] = (
    "config.json",
    "generation_config.json",
    "model.safetensors",
    "tokenizer.json",
    "tokenizer_config.json",
    PLANNER_META_FILE,
)
"""What a default checkpoint holds besides its card and evaluation (never the optimizer state)."""
OPTIONAL_FILES: tuple[str, ...] = (PLAN_VOCAB_FILE,)
"""Copied when the run has them (a decoder that writes whole plan words)."""

EVALUATION_FILE = "evaluation.json"
MODEL_CARD_FILE = "MODEL_CARD.md"


def _percent(value: object) -> str:
    return f"{float(str(value)):.1%}"


def per_task_tables(sets: Sequence[Mapping[str, Any]]) -> list[str]:
    """Exact match and F1 per task type, one small table per evaluation set."""
    lines: list[str] = []
    for report in sets:
        lines += [
            f"**{report['name']}**",
            "",
            "| task type | n | exact match | normalised | Navigate ignored | F1 |",
            "|---|---|---|---|---|---|",
        ]
        for task, s in report["per_task_type"].items():
            lines.append(
                f"| {task} | {s['count']} | {_percent(s['exact_match'])} | "
                f"{_percent(s['exact_match_container_normalised'])} | "
                f"{_percent(s['exact_match_interactions'])} | {s['f1']:.3f} |"
            )
        lines.append("")
    return lines


def render_model_card(
    meta: Mapping[str, Any],
    evaluation: Mapping[str, Any],
    size_bytes: int,
    commands: Sequence[str],
    comparison: Mapping[str, Any] | None = None,
    notes: str = "",
) -> str:
    """The card's Markdown: what the model is, its data, how it was made, what it scores, its size."""
    train = meta.get("train_config", {})
    continued = " from an earlier run's weights (`--init-from`)" if meta.get("initialised_from") else ""
    lines = [
        "# Language planner (default checkpoint)",
        "",
        "The JARVIS seed's Language Planning Module (Sec. 3, appendix A): dialogue turns joined with "
        "`<COM>`/`<FOL>` (an ALFRED goal after `<INS>`), history subgoals (without Navigate) after `<HIS>`, "
        "generating the future subgoals in DESIGN.md §5's text form with a beam of 4. Every output is "
        "validated against the ontology (`models/planner/predict.py`) and repaired by `symbolic.repair` in "
        "the agent.",
        "",
        "## Model",
        "",
        f"- recipe: `{meta.get('recipe')}`; architecture: `{json.dumps(meta.get('architecture'))}`",
        f"- parameters: {meta.get('parameters'):,}; weights: {meta.get('weights_dtype')} safetensors; "
        f"checkpoint size: {size_bytes / 2**20:.1f} MiB",
        "- tokenizer: "
        + (
            "byte-level BPE trained on the training set's inputs and targets, lower-cased"
            if meta.get("recipe") == "bart-scratch"
            else "MiniLM's uncased WordPiece cut to its common pieces and the corpus's, with the "
            "planner's marks added; the decoder writes whole plan words (`plan_vocab.json`: the nine "
            "actions and the ontology's types) held to the action/type grammar in beam search"
        ),
        "",
        "## Data",
        "",
        f"- {meta.get('train_examples'):,} training examples (file sha256 `{meta.get('data_fingerprint')}`): "
        "ALFRED train `task_desc` and joined `high_descs` -> subgoals of `plan.low_actions` (each "
        "trajectory's goal also with part and with all of its plan done after `<HIS>`), and the harness's "
        "generated TEACh-format EDH/TfD train instances (each game's first request also alone, its "
        "greeting and frame taken off, as a curl user types it); 3% of train trajectories/games held out "
        "as dev. "
        "ALFRED valid_seen and generated valid_unseen never enter training.",
        "",
        "## Training",
        "",
        f"- {meta.get('step')} steps of batch {train.get('batch_size')}{continued}, AdamW at "
        f"{train.get('learning_rate')} with {train.get('warmup_steps')} warm-up steps and linear decay, "
        f"label smoothing {train.get('label_smoothing')}, seed {train.get('seed')}; final dev loss "
        f"{_rounded(meta.get('dev_loss'))}",
        "- commands:",
        "",
        "```",
        *commands,
        "```",
        "",
        "## Evaluation",
        "",
        f"Beam {evaluation.get('num_beams')}{_bias_phrase(evaluation.get('navigate_bias'))}; written by "
        "`python -m models.planner evaluate` to "
        f"`{EVALUATION_FILE}` beside this card. Exact match compares whole subgoal sequences; the "
        "normalised one first drops Open/Close of a container an object is only fetched from (language "
        "cannot know where the expert found it); the last ignores Navigate (written only where the expert "
        "walked; the agent's repair navigates to every object out of reach).",
        "",
        format_report_table(evaluation["sets"]),
        "",
        *_miss_section(evaluation["sets"]),
        "### Per task type",
        "",
        *per_task_tables(evaluation["sets"]),
    ]
    if comparison is not None:
        lines += [
            "## Compared with the other backbone",
            "",
            f"{_compared_model(comparison)} on the same sets:",
            "",
            format_report_table(comparison["sets"]),
            "",
        ]
    if notes.strip():
        lines += [notes.strip(), ""]
    return "\n".join(lines)


def _miss_section(sets: Sequence[Mapping[str, Any]]) -> list[str]:
    """Why plans missed, when the evaluation counted it (``evaluate.miss_kind``)."""
    if not any("misses" in report for report in sets):
        return []
    return [
        "### Why plans missed",
        "",
        "Each miss counted once, under the first reason that applies: only Navigate steps differ; only the "
        "Open/Close of a container something is fetched from; the plan stops before the reference or runs "
        "past it; the same actions on other objects; other or reordered actions.",
        "",
        format_miss_table(sets),
        "",
    ]


def export_checkpoint(
    final_dir: Path,
    destination: Path,
    evaluation_path: Path,
    commands: Sequence[str],
    comparison_path: Path | None = None,
    notes: str = "",
) -> int:
    """Copy a run's ``final/`` to ``destination`` with its evaluation and card; returns the size in bytes."""
    missing = [name for name in CHECKPOINT_FILES if not (final_dir / name).is_file()]
    if missing:
        raise FileNotFoundError(f"{final_dir} lacks {missing}; is it a finished run's final/ folder?")
    destination.mkdir(parents=True, exist_ok=True)
    files = [*CHECKPOINT_FILES, *(name for name in OPTIONAL_FILES if (final_dir / name).is_file())]
    for name in OPTIONAL_FILES:
        (destination / name).unlink(missing_ok=True)  # a previous default's vocabulary must not linger
    for name in files:
        shutil.copyfile(final_dir / name, destination / name)
    shutil.copyfile(evaluation_path, destination / EVALUATION_FILE)
    evaluation = json.loads(evaluation_path.read_text(encoding="utf-8"))
    comparison = json.loads(comparison_path.read_text(encoding="utf-8")) if comparison_path else None
    size = sum((destination / name).stat().st_size for name in files)
    card = render_model_card(read_planner_meta(final_dir), evaluation, size, commands, comparison, notes)
    (destination / MODEL_CARD_FILE).write_text(card, encoding="utf-8")
    return size


def _compared_model(evaluation: Mapping[str, Any]) -> str:
    """How the card names the other backbone: its recipe and steps (older files only knew a path)."""
    if evaluation.get("recipe") is None:
        return f"`{evaluation.get('checkpoint')}`"
    return f"The `{evaluation['recipe']}` recipe after {evaluation['step']:,} steps"


def _bias_phrase(bias: object) -> str:
    """The Navigate bias the evaluation decoded with, when it had one (``calibrate`` chose it)."""
    return f" with the Navigate bias of {bias} that `calibrate` chose" if bias else ""


def _rounded(value: object) -> object:
    """A loss as a reader compares it (four places); anything else as recorded."""
    return round(value, 4) if isinstance(value, float) else value
