"""python -m models.goal_transformer render-data|train|evaluate: the goal transformer's data and training.

- render-data --out-dir DIR [--split train|valid_unseen] [--episodes N]: the harness's search-phase expert
  (python -m harness.perception_data search) in a subprocess, since models never imports the harness.
- train --episodes DIR --out-dir CKPT [--valid DIR] [--epochs N]: trains or resumes (--run-dir).
- evaluate --checkpoint CKPT --episodes DIR [--out FILE]: step and first-step action accuracy.

torch is imported inside the commands, so --help answers at once.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

from symbolic.cli_args import Parser, existing_dir, int_at_least, plain, positive_float


def _parser() -> argparse.ArgumentParser:
    parser = Parser(prog="python -m models.goal_transformer", description=plain(__doc__))
    sub = parser.add_subparsers(dest="command", required=True)
    positive = int_at_least(1)
    render = sub.add_parser("render-data", help="render search-phase episodes from the harness")
    render.add_argument("--out-dir", type=Path, required=True, help="folder to write (created)")
    render.add_argument("--split", choices=("train", "valid_unseen"), default="train")
    render.add_argument("--episodes", type=positive, default=300, help="episodes to render")
    render.add_argument("--seed", type=int, default=0)
    fit = sub.add_parser("train", help="train (or resume) the goal transformer")
    fit.add_argument("--episodes", type=existing_dir, required=True, help="folder written by render-data")
    fit.add_argument("--valid", type=existing_dir, default=None, help="validation episodes folder")
    fit.add_argument("--out-dir", type=Path, required=True, help="checkpoint folder to write")
    fit.add_argument("--run-dir", type=Path, default=Path("runs/goal_transformer"), help="resumable state")
    fit.add_argument("--epochs", type=positive, default=60)
    fit.add_argument("--batch-size", type=positive, default=8)
    fit.add_argument("--learning-rate", type=positive_float, default=3e-4)
    fit.add_argument("--seed", type=int, default=0)
    fit.add_argument("--threads", type=positive, default=2, help="torch threads")
    check = sub.add_parser("evaluate", help="action accuracy of a checkpoint on episodes")
    check.add_argument("--checkpoint", type=existing_dir, required=True)
    check.add_argument("--episodes", type=existing_dir, required=True, help="folder written by render-data")
    check.add_argument("--out", type=Path, default=None, help="also write the metrics here (JSON)")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    if args.command == "render-data":
        command = [
            sys.executable, "-m", "harness.perception_data", "search", "--out-dir", str(args.out_dir),
            "--split", args.split, "--episodes", str(args.episodes), "--seed", str(args.seed),
        ]  # fmt: skip
        return subprocess.call(command)
    import torch

    if args.command == "train":
        from models.goal_transformer.train import GoalTrainConfig, train_goal_transformer

        config = GoalTrainConfig(
            episodes=args.episodes,
            out=args.out_dir,
            run_dir=args.run_dir,
            valid_episodes=args.valid,
            epochs=args.epochs,
            batch=args.batch_size,
            lr=args.learning_rate,
            seed=args.seed,
            threads=args.threads,
        )
        out = train_goal_transformer(config)
        print(f"checkpoint written to {out}")
        print(json.dumps(json.loads((out / "config.json").read_text())["metrics"], indent=1))
        return 0
    from models.goal_transformer.dataset import load_episodes
    from models.goal_transformer.encoder import load_frame_encoder
    from models.goal_transformer.evaluate import action_accuracy
    from models.goal_transformer.model import load_goal_transformer

    torch.set_num_threads(2)
    model = load_goal_transformer(args.checkpoint)
    episodes = load_episodes(args.episodes, model.config, load_frame_encoder())
    metrics = {"checkpoint": str(args.checkpoint), **action_accuracy(model, episodes)}
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(metrics, indent=1))
    print(json.dumps(metrics, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
