"""python -m models.perception render-data|train|add-colour|evaluate: the U-Nets' data, training, metrics.

- render-data --out-dir DIR [--split train|valid_unseen] [--worlds N] ...: runs the harness's frame renderer
  (python -m harness.perception_data frames, whose --help lists the options) in a subprocess with the
  arguments as given, since models never imports the harness.
- train --network depth|segmentation --frames DIR --out-dir CKPT [--valid DIR] [--steps N] ...: trains or
  resumes (run state in --run-dir, default runs/perception/NETWORK), exports CKPT. --stop-at-step K
  stops at step K of the --steps schedule; a rerun with another --side resumes at that side.
- add-colour --checkpoint CKPT --frames DIR --out-dir CKPT2 [--valid DIR]: fits the per-pixel colour
  expert (colour.py, colour_fit.py) of a segmentation checkpoint on pixels of the frames, exports.
- evaluate --checkpoint CKPT --frames DIR [--out FILE]: prints and writes the metrics.

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
    parser = Parser(prog="python -m models.perception", description=plain(__doc__))
    sub = parser.add_subparsers(dest="command", required=True)
    count, positive = int_at_least(0), int_at_least(1)

    sub.add_parser(
        "render-data",
        help="render frames from the harness into the dataset layout "
        "(options: python -m harness.perception_data frames --help)",
    )

    fit = sub.add_parser("train", help="train (or resume) a depth or segmentation network")
    fit.add_argument("--network", choices=("depth", "segmentation"), required=True)
    fit.add_argument("--frames", type=existing_dir, required=True, help="training frames folder")
    fit.add_argument(
        "--valid", type=existing_dir, default=None, help="validation frames folder (evaluated at the end)"
    )
    fit.add_argument("--out-dir", type=Path, required=True, help="checkpoint folder to write")
    fit.add_argument(
        "--run-dir", type=Path, default=None, help="resumable state (default runs/perception/NETWORK)"
    )
    fit.add_argument("--side", type=int_at_least(16), default=128, help="network input side, pixels")
    fit.add_argument("--crop", type=int_at_least(16), default=None, help="train on random crops of this side")
    fit.add_argument("--widths", type=str, default="16,32,64,96,128", help="U-Net channels per level")
    fit.add_argument("--bin-m", type=positive_float, default=0.1, help="depth bin width, metres")
    fit.add_argument("--bins", type=positive, default=50, help="number of depth bins")
    fit.add_argument("--steps", type=positive, default=3000, help="length of the learning-rate schedule")
    fit.add_argument(
        "--stop-at-step", type=positive, default=None, help="stop and export at this step (rerun to continue)"
    )
    fit.add_argument("--depth-target", choices=("one_hot", "two_hot"), default="one_hot")
    fit.add_argument(
        "--depth-l1", type=float, default=0.0, help="weight of the expected depth's relative L1 loss"
    )
    fit.add_argument("--batch-size", type=positive, default=12)
    fit.add_argument("--learning-rate", type=positive_float, default=2e-3, help="peak learning rate")
    fit.add_argument("--seed", type=int, default=0)
    fit.add_argument("--threads", type=positive, default=2, help="torch threads")
    fit.add_argument("--limit", type=positive, default=None, help="use only the first N training frames")
    fit.add_argument("--valid-limit", type=positive, default=None)
    fit.add_argument(
        "--init-from", type=existing_dir, default=None, help="start from this exported checkpoint's weights"
    )

    fit.add_argument(
        "--colour-hidden",
        type=count,
        default=0,
        help="segmentation: train a per-pixel colour expert of this width alongside (colour.py); "
        "add-colour fits one to a trained network in minutes",
    )

    colour = sub.add_parser("add-colour", help="fit the colour expert of a segmentation checkpoint")
    colour.add_argument(
        "--checkpoint", type=existing_dir, required=True, help="segmentation checkpoint to extend"
    )
    colour.add_argument("--frames", type=existing_dir, required=True, help="training frames folder")
    colour.add_argument("--out-dir", type=Path, required=True, help="checkpoint folder to write")
    colour.add_argument(
        "--valid", type=existing_dir, default=None, help="validation frames (evaluated at the end)"
    )
    colour.add_argument("--valid-limit", type=positive, default=None)
    colour.add_argument("--eval-side", type=int_at_least(16), default=256)
    colour.add_argument("--limit", type=positive, default=None, help="use only the first N training frames")
    fit_defaults = "(default: colour_fit.ColourFitConfig's)"
    colour.add_argument("--hidden", type=positive, help=f"hidden width {fit_defaults}")
    colour.add_argument("--pixels", type=positive, help=f"pixels sampled {fit_defaults}")
    colour.add_argument("--epochs", type=positive, help=f"passes over them {fit_defaults}")
    colour.add_argument("--threads", type=positive, default=2, help="torch threads")

    check = sub.add_parser("evaluate", help="metrics of a checkpoint on a frames folder")
    check.add_argument("--checkpoint", type=existing_dir, required=True)
    check.add_argument("--frames", type=existing_dir, required=True)
    check.add_argument("--eval-side", type=int_at_least(16), default=256)
    check.add_argument("--limit", type=positive, default=None)
    check.add_argument("--out", type=Path, default=None, help="also write the metrics here (JSON)")
    check.add_argument(
        "--precision",
        choices=("auto", "float32", "bfloat16"),
        default="auto",
        help="the network's arithmetic; auto (as the agent runs it): bfloat16 where the CPU has it natively",
    )
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    arguments = list(sys.argv[1:] if argv is None else argv)
    if arguments[:1] == ["render-data"]:  # the harness's parser owns these options (and their --help)
        return subprocess.call([sys.executable, "-m", "harness.perception_data", "frames", *arguments[1:]])
    args = _parser().parse_args(arguments)
    import torch

    if args.command == "train":
        from models.perception.train import TrainConfig, train

        config = TrainConfig(
            task=args.network,
            frames=args.frames,
            out=args.out_dir,
            run_dir=args.run_dir or Path("runs/perception") / args.network,
            valid_frames=args.valid,
            side=args.side,
            crop=args.crop,
            widths=tuple(int(w) for w in args.widths.split(",")),
            bin_m=args.bin_m,
            bins=args.bins,
            steps=args.steps,
            stop_at=args.stop_at_step,
            depth_target=args.depth_target,
            depth_l1_weight=args.depth_l1,
            batch=args.batch_size,
            lr=args.learning_rate,
            seed=args.seed,
            threads=args.threads,
            limit=args.limit,
            valid_limit=args.valid_limit,
            init_from=args.init_from,
            colour_hidden=args.colour_hidden,
        )
        out = train(config)
        print(f"checkpoint written to {out}")
        print((out / "config.json").read_text())
        return 0
    if args.command == "add-colour":
        from models.perception.colour_fit import ColourFitConfig, add_colour_expert

        torch.set_num_threads(args.threads)
        chosen = {"hidden": args.hidden, "pixels": args.pixels, "epochs": args.epochs}
        fit = ColourFitConfig(**{name: value for name, value in chosen.items() if value is not None})
        out = add_colour_expert(
            args.checkpoint,
            args.frames,
            args.out_dir,
            fit,
            limit=args.limit,
            valid=args.valid,
            valid_limit=args.valid_limit,
            eval_side=args.eval_side,
        )
        print(f"checkpoint written to {out}")
        print((out / "config.json").read_text())
        return 0
    from models.perception.evaluate import evaluate_checkpoint, write_metrics

    torch.set_num_threads(2)
    metrics = evaluate_checkpoint(args.checkpoint, args.frames, args.eval_side, args.limit, args.precision)
    if args.out is not None:
        write_metrics(args.out, metrics)
    print(json.dumps(metrics, indent=1, sort_keys=True))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
