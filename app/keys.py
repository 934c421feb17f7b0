"""API keys: who is calling, and how much that key may use (DESIGN.md §4).

Keys come from ``JARVIS_API_KEYS`` (comma-separated ``name:sha256-hex`` entries) and/or the JSON-lines file
``JARVIS_API_KEYS_FILE`` (``{"name", "sha256", "max_sessions"?, "rate_per_s"?, "burst"?}`` per line). Only
SHA-256 hashes are ever configured or held, so a leaked configuration leaks no key. With no key configured
the service runs open, as it always did, and says so when it starts.

A request names its key as ``Authorization: Bearer KEY``, ``X-API-Key: KEY``, or HTTP Basic auth with the key
as password, or as user name with no password: TEACh's unmodified ``RemoteModel`` builds its URLs from
``--model_api_host_and_port``, so ``KEY@host:port`` there makes ``requests`` send it as Basic auth.

``python -m app.keys new NAME`` makes a fresh key and prints the line to configure.
"""

from __future__ import annotations

import argparse
import base64
import binascii
import hashlib
import json
import re
import secrets
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

KEY_NAME = re.compile(r"^[A-Za-z0-9._-]{1,64}$")
"""Key names label sessions in the store and metrics: short, no separators."""
_SHA256_HEX = re.compile(r"^[0-9a-f]{64}$")


class KeyConfigError(ValueError):
    """The configured keys cannot be read; the message names the entry and what is wrong."""


@dataclass(frozen=True)
class ApiKey:
    """One configured key: its name (the owner of its sessions), the hash of its secret, its quotas (None:
    the service's defaults)."""

    name: str
    sha256: str
    max_sessions: int | None = None
    rate_per_s: float | None = None
    burst: int | None = None


def hash_key(secret: str) -> str:
    return hashlib.sha256(secret.encode("utf-8")).hexdigest()


def _key(name: str, sha256: str, where: str, **quotas: object) -> ApiKey:
    if not KEY_NAME.match(name):
        raise KeyConfigError(f"{where}: key name {name!r} must be 1-64 characters of A-Z a-z 0-9 . _ -")
    digest = sha256.strip().lower()
    if not _SHA256_HEX.match(digest):
        raise KeyConfigError(
            f"{where}: key {name!r} needs the SHA-256 hex digest of the key (64 hex digits), not the key "
            "itself; `python -m app.keys new NAME` prints one"
        )
    for field, value in quotas.items():
        if value is not None and (
            not isinstance(value, int | float) or isinstance(value, bool) or value <= 0
        ):
            raise KeyConfigError(f"{where}: key {name!r}: {field} must be a positive number, got {value!r}")
    max_sessions = quotas.get("max_sessions")
    rate = quotas.get("rate_per_s")
    burst = quotas.get("burst")
    return ApiKey(
        name,
        digest,
        int(max_sessions) if isinstance(max_sessions, int | float) else None,
        float(rate) if isinstance(rate, int | float) else None,
        int(burst) if isinstance(burst, int | float) else None,
    )


def parse_key_list(text: str) -> list[ApiKey]:
    """``name:sha256,name:sha256`` (the ``JARVIS_API_KEYS`` setting)."""
    keys = []
    for index, entry in enumerate(part.strip() for part in text.split(",")):
        if not entry:
            continue
        name, sep, digest = entry.partition(":")
        if not sep:
            raise KeyConfigError(
                f"JARVIS_API_KEYS entry {index}: expected name:sha256-hex, got {entry[:20]!r}"
            )
        keys.append(_key(name.strip(), digest, f"JARVIS_API_KEYS entry {index}"))
    return keys


def read_key_file(path: Path) -> list[ApiKey]:
    """The JSON-lines keys file; blank lines and lines starting with ``#`` are skipped."""
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except OSError as error:
        raise KeyConfigError(f"JARVIS_API_KEYS_FILE {path}: cannot be read ({error.strerror})") from error
    keys = []
    for number, line in enumerate(lines, start=1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        where = f"{path}:{number}"
        try:
            entry = json.loads(line)
        except json.JSONDecodeError as error:
            raise KeyConfigError(f"{where}: not JSON ({error.msg})") from error
        if not isinstance(entry, dict) or not isinstance(entry.get("name"), str):
            raise KeyConfigError(f'{where}: expected {{"name": ..., "sha256": ...}}')
        unknown = set(entry) - {"name", "sha256", "max_sessions", "rate_per_s", "burst"}
        if unknown:
            raise KeyConfigError(f"{where}: unknown fields {', '.join(sorted(unknown))}")
        keys.append(
            _key(
                entry["name"],
                str(entry.get("sha256", "")),
                where,
                max_sessions=entry.get("max_sessions"),
                rate_per_s=entry.get("rate_per_s"),
                burst=entry.get("burst"),
            )
        )
    return keys


class KeyRing:
    """The configured keys by hash; empty means the service is open."""

    def __init__(self, keys: Sequence[ApiKey]) -> None:
        by_hash: dict[str, ApiKey] = {}
        names: set[str] = set()
        for key in keys:
            if key.name in names:
                raise KeyConfigError(f"key name {key.name!r} is configured twice")
            if key.sha256 in by_hash:
                raise KeyConfigError(f"keys {by_hash[key.sha256].name!r} and {key.name!r} are the same key")
            names.add(key.name)
            by_hash[key.sha256] = key
        self._by_hash = by_hash

    @classmethod
    def configured(cls, key_list: str | None, key_file: Path | None) -> KeyRing:
        keys = parse_key_list(key_list) if key_list else []
        if key_file is not None:
            keys += read_key_file(key_file)
        return cls(keys)

    @property
    def open(self) -> bool:
        return not self._by_hash

    def __len__(self) -> int:
        return len(self._by_hash)

    def identify(self, secret: str) -> ApiKey | None:
        return self._by_hash.get(hash_key(secret))


def presented_key(headers: Mapping[str, str]) -> str | None:
    """The key a request presents (see the module docstring), or None."""
    api_key = headers.get("x-api-key")
    if api_key:
        return api_key.strip()
    scheme, _, value = headers.get("authorization", "").strip().partition(" ")
    if scheme.lower() == "bearer" and value.strip():
        return value.strip()
    if scheme.lower() == "basic" and value.strip():
        try:
            user, _, password = base64.b64decode(value.strip(), validate=True).decode("utf-8").partition(":")
        except (binascii.Error, UnicodeDecodeError):
            return None
        return password or user or None  # KEY@host sends the key as user name, no password
    return None


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m app.keys",
        description="Make an API key for the service (only its hash is configured).",
    )
    commands = parser.add_subparsers(dest="command", required=True)
    new = commands.add_parser("new", help="print a fresh key and the entry that configures it")
    new.add_argument("name", help="the key's name: the owner of the sessions made with it")
    args = parser.parse_args(argv)
    if not KEY_NAME.match(args.name):
        parser.error(f"name {args.name!r} must be 1-64 characters of A-Z a-z 0-9 . _ -")
    secret = "jv_" + secrets.token_urlsafe(32)
    digest = hash_key(secret)
    sys.stdout.write(
        f"key (give it to the client; it is not stored anywhere): {secret}\n"
        f"JARVIS_API_KEYS entry: {args.name}:{digest}\n"
        f"JARVIS_API_KEYS_FILE line: {json.dumps({'name': args.name, 'sha256': digest})}\n"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
