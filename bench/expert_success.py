"""Expert success per task: TEACh's 12 benchmark tasks on generated worlds, ALFRED valid_seen when present.

For each TEACh task, ``--n`` (world, task) pairs sampled as the episode generator samples them; for
ALFRED, the valid_seen trajectories' worlds and tasks (all 251 unless ``--alfred-limit``). Prints one line
per episode and a table per suite (success rate against the 95 % bar, the commonest failure, mean length
and time) and writes everything, failure histograms and every episode, to
``bench/results/expert_success.json``. The command is ``python -m harness expert`` with that default output.

Run: ``.venv/bin/python -m bench.expert_success [--n 25] [--task Coffee ...] [--no-alfred]``.
"""

from __future__ import annotations

import sys
from pathlib import Path

from harness.expert.cli import main

RESULTS = Path(__file__).resolve().parent / "results" / "expert_success.json"

if __name__ == "__main__":
    main(sys.argv[1:], default_out=RESULTS)
