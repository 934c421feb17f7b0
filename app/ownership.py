"""Who owns a session and how many a caller may hold: the caller, its cap, and the 429 when it is reached."""

from __future__ import annotations

from dataclasses import dataclass

from app.errors import TOO_MANY_SESSIONS, ApiError
from app.keys import ApiKey
from app.rate_limit import retry_after_header
from app.settings import Settings
from app.store import StoreFull


@dataclass(frozen=True)
class Caller:
    """Who sent the request: the owner of the sessions it may use (the key's name; None when open)."""

    owner: str | None
    key: ApiKey | None


def too_many_sessions(error: StoreFull, settings: Settings) -> ApiError:
    """429 ``too_many_sessions`` with Retry-After: when the oldest idle session (of the key) expires."""
    if error.per_owner:
        setting = "JARVIS_MAX_SESSIONS_PER_KEY, or the key's own max_sessions"
    else:
        setting = f"JARVIS_MAX_SESSIONS={settings.max_sessions}"
    return ApiError(
        429,
        TOO_MANY_SESSIONS,
        f"{error}; delete finished sessions or wait for idle ones to expire (setting {setting}; idle TTL "
        f"JARVIS_SESSION_TTL_S={settings.session_ttl_s})",
        headers={"Retry-After": retry_after_header(error.retry_after_s)},
    )


def owner_cap(caller: Caller, settings: Settings) -> int | None:
    """The caller's live-session cap: its key's own, else the setting; none when the service is open."""
    if caller.key is None:
        return None
    return caller.key.max_sessions or settings.max_sessions_per_key
