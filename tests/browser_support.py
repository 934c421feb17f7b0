"""Debian's headless Chromium for the browser tests (the live page, the API docs): where it is and how it
starts. ``make test`` installs it when missing; playwright only drives it (its own browser download is never
used). The flags keep Chromium off the network beyond loopback, which this machine closes anyway."""

from __future__ import annotations

from pathlib import Path

CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]
