"""Expert success per task: TEACh's 12 benchmark tasks on generated worlds, ALFRED valid_seen when present.

For each TEACh task, ``--n`` (world, task) pairs sampled as the episode generator samples them; for
ALFRED, the valid_seen trajectories' worlds and tasks (all 251 unless ``--alfred-limit``). Prints one line
per episode and a table per suite (success rate against the 95 % bar, the commonest failure, mean length
and time) and writes everything, failure histograms and every episode, to
``bench/results/expert_success.json``. The command is ``python -m harness expert`` with that default output;
this script adds the stamp to the file the command wrote.

Run: ``.venv/bin/python -m bench.expert_success [--n 25] [--task Coffee ...] [--no-alfred]``.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path

from bench.stamp import BenchRun, results_path
from harness.expert.cli import main as expert_main

RESULTS = results_path("expert_success")


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m harness expert`` writing to ``bench/results/``, its report stamped; its exit code."""
    arguments = list(argv) if argv is not None else sys.argv[1:]
    run = BenchRun.start("expert_success", arguments)
    code = expert_main(arguments, default_out=RESULTS)
    out_option = argparse.ArgumentParser(add_help=False)
    out_option.add_argument("--out", type=Path, default=RESULTS)
    out = out_option.parse_known_args(arguments)[0].out
    run.write(out, json.loads(out.read_text(encoding="utf-8")))
    return code


if __name__ == "__main__":
    sys.exit(main())
