"""``python -m harness <command>``: the harness's command line.

Each command lives in its own module with a ``main(argv) -> int``; this file only dispatches, importing the
chosen module lazily so ``--help`` stays fast.
"""

from __future__ import annotations

import importlib
import sys

COMMANDS: dict[str, tuple[str, str]] = {
    "demo": (
        "harness.drive.demo",
        "start the service, run one kitchen TEACh episode over HTTP, show the results",
    ),
    "run": ("harness.drive.run_cli", "drive one episode through a running service and print its metrics"),
    "generate": ("harness.episodes.generate", "write TEACh-format games, EDH and TfD instances"),
    "expert": ("harness.expert.cli", "measure the expert's success rate per task, with failure reasons"),
    "commander": ("harness.commander.cli", "one TATC episode: the commander bot talks to the follower"),
    "eval": (
        "harness.drive.evaluate",
        "run a benchmark's episodes against the service; resumable TEACh metrics",
    ),
}


def main(argv: list[str] | None = None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    if not args or args[0] in ("-h", "--help") or args[0] not in COMMANDS:
        known = "\n".join(f"  {name:<10} {help_}" for name, (_, help_) in COMMANDS.items())
        print(f"usage: python -m harness <command> [options]\n\ncommands:\n{known}")
        return 0 if args and args[0] in ("-h", "--help") else 2
    module = importlib.import_module(COMMANDS[args[0]][0])
    return int(module.main(args[1:]))


if __name__ == "__main__":
    sys.exit(main())
