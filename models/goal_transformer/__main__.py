"""``python -m models.goal_transformer render-data|train|evaluate``: the goal transformer's data and training.

- ``render-data --out DIR [--split train|valid_unseen] [--episodes N]``: the harness's search-phase expert
  (``python -m harness.perception_data search``) in a subprocess, since ``models`` never imports the harness.
- ``train --episodes DIR --out CKPT [--valid DIR] [--epochs N]``: trains or resumes (``--run-dir``).
- ``evaluate --checkpoint CKPT --episodes DIR [--json FILE]``: step and first-step action accuracy.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

import torch

from models.goal_transformer.dataset import load_episodes
from models.goal_transformer.encoder import load_frame_encoder
from models.goal_transformer.evaluate import action_accuracy
from models.goal_transformer.model import load_goal_transformer
from models.goal_transformer.train import GoalTrainConfig, train_goal_transformer


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m models.goal_transformer", description=__doc__.split("\n")[0]
    )
    sub = parser.add_subparsers(dest="command", required=True)
    render = sub.add_parser("render-data", help="render search-phase episodes from the harness")
    render.add_argument("--out", type=Path, required=True)
    render.add_argument("--split", choices=("train", "valid_unseen"), default="train")
    render.add_argument("--episodes", type=int, default=300)
    render.add_argument("--seed", type=int, default=0)
    fit = sub.add_parser("train", help="train (or resume) the goal transformer")
    fit.add_argument("--episodes", type=Path, required=True)
    fit.add_argument("--valid", type=Path, default=None)
    fit.add_argument("--out", type=Path, required=True)
    fit.add_argument("--run-dir", type=Path, default=Path("runs/goal_transformer"))
    fit.add_argument("--epochs", type=int, default=60)
    fit.add_argument("--batch", type=int, default=8)
    fit.add_argument("--lr", type=float, default=3e-4)
    fit.add_argument("--seed", type=int, default=0)
    fit.add_argument("--threads", type=int, default=2)
    check = sub.add_parser("evaluate", help="action accuracy of a checkpoint on episodes")
    check.add_argument("--checkpoint", type=Path, required=True)
    check.add_argument("--episodes", type=Path, required=True)
    check.add_argument("--json", type=Path, default=None)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    if args.command == "render-data":
        command = [
            sys.executable, "-m", "harness.perception_data", "search", "--out", str(args.out),
            "--split", args.split, "--episodes", str(args.episodes), "--seed", str(args.seed),
        ]  # fmt: skip
        return subprocess.call(command)
    if args.command == "train":
        config = GoalTrainConfig(
            episodes=args.episodes,
            out=args.out,
            run_dir=args.run_dir,
            valid_episodes=args.valid,
            epochs=args.epochs,
            batch=args.batch,
            lr=args.lr,
            seed=args.seed,
            threads=args.threads,
        )
        out = train_goal_transformer(config)
        print(f"checkpoint written to {out}")
        print(json.dumps(json.loads((out / "config.json").read_text())["metrics"], indent=1))
        return 0
    torch.set_num_threads(2)
    model = load_goal_transformer(args.checkpoint)
    episodes = load_episodes(args.episodes, model.config, load_frame_encoder())
    metrics = {"checkpoint": str(args.checkpoint), **action_accuracy(model, episodes)}
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(metrics, indent=1))
    print(json.dumps(metrics, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
