"""Make a trained run the default checkpoint: its fp16 weights, its evaluation, a model card and a history.

DESIGN.md §7: every default checkpoint has a model card saying its data, the command that made it, its
metrics and its size. It follows the Hugging Face Hub's conventions: ``README.md`` with YAML metadata on
top and a loading snippet of plain transformers calls, one screen long; the long tables and the experiment
history go to ``HISTORY.md`` beside it. Both are written from the run's ``planner_meta.json`` and the JSON
that ``python -m models.planner evaluate --out`` wrote, so the numbers they quote are the measured ones.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from transformers import AutoConfig

from models.planner.evaluate import format_miss_table, format_report_table
from models.planner.hub import PLAN_TOKENIZER_DIR, trained_input_length, write_hub_files
from models.planner.modeling import MINILM_HUB_ID, PLANNER_META_FILE, read_planner_meta
from models.planner.plan_vocab import PLAN_VOCAB_FILE, PlanVocabulary
from models.planner.predict import NAVIGATE_BIAS_KEY
from models.portable_paths import portable_record

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


MODEL_CARD_FILE = "README.md"
"""The Hub's model card: YAML metadata, then one screen saying what it is, its data, command and metrics."""
HISTORY_FILE = "HISTORY.md"
"""Beside the card: per-task and miss tables, the other backbone, and the experiment history (``notes``)."""
HUB_TAGS: tuple[str, ...] = ("embodied-ai", "task-planning", "teach", "alfred", "jarvis", "encoder-decoder")


def _yaml_string(value: object) -> str:
    """A YAML scalar: JSON's quoted string is valid YAML and needs no escaping rules of its own."""
    return json.dumps(str(value))


def _front_matter(meta: Mapping[str, Any], evaluation: Mapping[str, Any]) -> list[str]:
    """The Hub's metadata block: licence, library, task, base model, tags, data, and each evaluation set's
    exact match and F1 as ``model-index`` results."""
    lines = [
        "---",
        "license: mit",
        "library_name: transformers",
        "pipeline_tag: text2text-generation",
    ]
    if meta.get("recipe") == "minilm-encdec":
        lines.append(f"base_model: {MINILM_HUB_ID}")
    lines += ["tags:", *(f"- {tag}" for tag in HUB_TAGS), "datasets:", "- alfred", "- teach", "metrics:"]
    lines += ["- exact_match", "- f1", "model-index:", "- name: jarvis-language-planner", "  results:"]
    for report in evaluation["sets"]:
        overall = report["overall"]
        lines += [
            "  - task:",
            "      type: text2text-generation",
            "      name: dialogue to subgoals",
            "    dataset:",
            f"      name: {_yaml_string(report['name'])}",
            f"      type: {report['name'].split('_')[0]}",
            "    metrics:",
            "    - type: exact_match",
            f"      value: {round(100 * float(overall['exact_match']), 1)}",
            "    - type: f1",
            f"      value: {round(float(overall['f1']), 3)}",
        ]
    return [*lines, "---", ""]


LOADING_SNIPPET = """\
from transformers import AutoModelForSeq2SeqLM, AutoTokenizer
path = "models/checkpoints/planner"  # this folder
model, reader = AutoModelForSeq2SeqLM.from_pretrained(path), AutoTokenizer.from_pretrained(path)
writer = AutoTokenizer.from_pretrained(path, subfolder="plan_tokenizer")  # the plan side

dialogues = [
    "<COM> make me a cup of coffee",
    "<COM> slice a tomato <FOL> where is the knife? <COM> in the drawer",
]
ids = model.generate(**reader(dialogues, padding=True, truncation=True, return_tensors="pt"))
plans = writer.batch_decode(ids, skip_special_tokens=True)
print(plans)  # one plan per dialogue: "Navigate Mug, Pickup Mug, ..."
"""
"""The card's loading snippet; ``tests/models/test_planner_hub_loading.py`` runs it as the card shows it."""


def render_model_card(
    meta: Mapping[str, Any],
    evaluation: Mapping[str, Any],
    size_bytes: int,
    commands: Sequence[str],
) -> str:
    """The card (README.md): metadata, what the model is, how to load it, its data, command and metrics."""
    train = meta.get("train_config", {})
    continued = " from an earlier run's weights (`--init-from`)" if meta.get("initialised_from") else ""
    plan_words = meta.get("recipe") == "minilm-encdec"
    lines = [
        *_front_matter(meta, evaluation),
        "# Language planner",
        "",
        "The JARVIS seed's Language Planning Module (Sec. 3, appendix A): a dialogue (turns after `<COM>` "
        "and `<FOL>`, an ALFRED goal after `<INS>`, subgoals already done after `<HIS>`) in, the future "
        "subgoals out in DESIGN.md §5's text form "
        "(`Navigate Knife, Pickup Knife, Navigate Bread, Slice Bread`). "
        f"`{meta.get('recipe')}`, {meta.get('parameters'):,} parameters, {meta.get('weights_dtype')} "
        f"safetensors, {size_bytes / 2**20:.1f} MiB. The service validates each plan against the ontology "
        "(`models/planner/predict.py`) and repairs it (`symbolic.repair`).",
        "",
        "## Load it",
        "",
        "```python",
        LOADING_SNIPPET.rstrip(),
        "```",
        "",
    ]
    if plan_words:
        lines += [
            "The decoder writes whole plan words (`plan_vocab.json`: the nine actions and the ontology's "
            "types); `plan_tokenizer/` turns them into text, and `generation_config.json` holds the "
            f"service's beam of {evaluation.get('num_beams')} and Navigate bias. The service also holds its "
            "beam search to the plan grammar (an action, then a type, ..., then the end), which `generate` "
            "cannot be told in a file: where the best beam breaks it, the two differ "
            f"(measured: `{HISTORY_FILE}`). "
            "In this repository `SubgoalGenerator.from_directory(path, ontology)` does all of it.",
            "",
        ]
    lines += [
        "## Data",
        "",
        f"{meta.get('train_examples'):,} examples (sha256 `{str(meta.get('data_fingerprint'))[:16]}…`): "
        "ALFRED train goals and joined step descriptions with the subgoals of their expert plans, and the "
        "harness's generated TEACh-format EDH/TfD train games (also each game's first request alone). "
        "ALFRED valid_seen and generated valid_unseen never enter training.",
        "",
        "## Training",
        "",
        f"{meta.get('step')} steps of batch {train.get('batch_size')}{continued}, AdamW at "
        f"{train.get('learning_rate')}, seed {train.get('seed')}, final dev loss "
        f"{_rounded(meta.get('dev_loss'))}:",
        "",
        "```",
        *commands,
        "```",
        "",
        "## Metrics",
        "",
        f"Beam {evaluation.get('num_beams')}{_bias_phrase(evaluation.get('navigate_bias'))}; "
        f"`{EVALUATION_FILE}` has every number, `{HISTORY_FILE}` the tables per task type, why plans missed, "
        "and how this checkpoint was chosen.",
        "",
        format_report_table(evaluation["sets"]),
        "",
    ]
    return "\n".join(lines)


def render_history(
    evaluation: Mapping[str, Any], comparison: Mapping[str, Any] | None = None, notes: str = ""
) -> str:
    """HISTORY.md: what the card leaves out: misses and scores per task type, the other backbone, and
    the experiment history (``notes``, written by hand)."""
    lines = [
        "# Language planner: evaluation details and experiment history",
        "",
        f"The model card is `{MODEL_CARD_FILE}`; every number here comes from `{EVALUATION_FILE}` unless "
        "a section says where else.",
        "",
        *_miss_section(evaluation["sets"]),
        "## Per task type",
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
        "## Why plans missed",
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
    """Copy a run's ``final/`` to ``destination`` with its evaluation, the files plain transformers calls
    need (``hub.py``), the card and the history; returns the size in bytes."""
    missing = [name for name in CHECKPOINT_FILES if not (final_dir / name).is_file()]
    if missing:
        raise FileNotFoundError(f"{final_dir} lacks {missing}; is it a finished run's final/ folder?")
    destination.mkdir(parents=True, exist_ok=True)
    files = [*CHECKPOINT_FILES, *(name for name in OPTIONAL_FILES if (final_dir / name).is_file())]
    for name in OPTIONAL_FILES:
        (destination / name).unlink(missing_ok=True)  # a previous default's vocabulary must not linger
    shutil.rmtree(destination / PLAN_TOKENIZER_DIR, ignore_errors=True)
    (destination / "MODEL_CARD.md").unlink(missing_ok=True)  # the card's name before the Hub's README.md
    for name in files:
        shutil.copyfile(final_dir / name, destination / name)
    meta = read_planner_meta(final_dir)
    bias = meta.get(NAVIGATE_BIAS_KEY)
    vocab = PlanVocabulary.load(destination)
    config = AutoConfig.from_pretrained(str(destination))
    navigate_bias = float(bias) if isinstance(bias, int | float) else 0.0
    write_hub_files(destination, config, vocab, navigate_bias, trained_input_length(meta))
    evaluation = portable_record(json.loads(evaluation_path.read_text(encoding="utf-8")))
    (destination / EVALUATION_FILE).write_text(json.dumps(evaluation, indent=2) + "\n", encoding="utf-8")
    comparison = json.loads(comparison_path.read_text(encoding="utf-8")) if comparison_path else None
    size = sum(path.stat().st_size for path in destination.rglob("*") if path.is_file())
    card = render_model_card(meta, evaluation, size, commands)
    (destination / MODEL_CARD_FILE).write_text(card, encoding="utf-8")
    history = render_history(evaluation, comparison, notes)
    (destination / HISTORY_FILE).write_text(history, encoding="utf-8")
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
