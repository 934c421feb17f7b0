"""What every command line of the project shares, so that flags, help and errors look the same everywhere.

The vocabulary (README "Command lines"): ``--batch-size``, ``--learning-rate``, ``--steps``, ``--out``
(always a file), ``--out-dir`` (always a folder), ``--run-dir`` (a resumable run's folder), ``--task``
(repeatable), ``--split``, ``--seed``, ``--workers``, ``--threads``, ``--url``. Here are the parser class
those commands build (defaults shown, plain-text descriptions, a bad argument answered by one line and exit
code 2) and the value types that turn a bad value into such a line instead of a traceback later.

Standard library only (symbolic/ may import nothing else), so a parser costs no heavy import.
"""

from __future__ import annotations

import argparse
import copy
import re
import sys
from collections.abc import Callable
from pathlib import Path
from typing import NoReturn
from urllib.parse import urlsplit

_REST_LITERAL = re.compile(r"``(.+?)``")


def plain(text: str | None) -> str:
    """A docstring as help text: reST's ``literal`` markers dropped (argparse prints them as they are)."""
    return _REST_LITERAL.sub(r"\1", text or "").strip()


def _shows_default(action: argparse.Action) -> bool:
    if action.default is None or action.default is False or action.default == argparse.SUPPRESS:
        return False
    if not action.option_strings:
        return False
    return not isinstance(action, argparse._HelpAction | argparse._VersionAction)


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Descriptions as written (paragraphs and lists kept); every option with a default says it."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        help_ = action.help or ""
        if "%(default)" in help_ or not _shows_default(action):
            return help_
        return f"{help_} (default: %(default)s)".lstrip()

    def _format_action(self, action: argparse.Action) -> str:
        if not action.help and _shows_default(action):
            action = copy.copy(action)
            action.help = "(default: %(default)s)"  # argparse prints no default for an option without help
        return super()._format_action(action)


class Parser(argparse.ArgumentParser):
    """``argparse.ArgumentParser`` with the project's formatter and one-line errors (exit code 2).

    Subcommands made with ``add_subparsers().add_parser`` are of this class too (argparse's default).
    """

    def __init__(self, *args: object, **kwargs: object) -> None:
        kwargs.setdefault("formatter_class", HelpFormatter)
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]

    def error(self, message: str) -> NoReturn:
        """One line, not the usage block: ``prog: error: message (see prog --help)``."""
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def fail(prog: str, message: str) -> NoReturn:
    """The one-line error of a command whose arguments parsed but name something unusable (exit code 2)."""
    sys.stderr.write(f"{prog}: error: {message}\n")
    raise SystemExit(2)


def int_at_least(minimum: int) -> Callable[[str], int]:
    """An ``int`` type for argparse that refuses values below ``minimum`` (``--index -5``, ``--camera 0``)."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be ≥ {minimum}, got {value}")
        return value

    return parse


def positive_float(text: str) -> float:
    """A ``float`` type for argparse that refuses zero, negative and non-finite values (a learning rate)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not 0 < value < float("inf"):
        raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
    return value


def existing_path(text: str) -> Path:
    """A file or folder that must exist now (a checkpoint, a data folder): refused before anything loads."""
    path = Path(text)
    if not path.exists():
        raise argparse.ArgumentTypeError(f"{text}: no such file or folder")
    return path


def existing_dir(text: str) -> Path:
    """A folder that must exist now (a checkpoint folder, frames written by render-data)."""
    path = existing_path(text)
    if not path.is_dir():
        raise argparse.ArgumentTypeError(f"{text}: not a folder")
    return path


def port(text: str) -> int:
    """A TCP port, 1..65535."""
    value = int_at_least(1)(text)
    if value > 65535:
        raise argparse.ArgumentTypeError(f"a port is 1..65535, got {value}")
    return value


def http_url(text: str) -> str:
    """A base URL ``http(s)://host[:port]``, trailing slash dropped; whether it answers is checked later."""
    parts = urlsplit(text)
    if parts.scheme not in ("http", "https") or not parts.hostname:
        raise argparse.ArgumentTypeError(f"expected http://host:port, got {text!r}")
    try:
        parts.port  # noqa: B018 - raises ValueError on a port that is not a number or out of range
    except ValueError:
        raise argparse.ArgumentTypeError(f"bad port in {text!r}") from None
    return text.rstrip("/")
