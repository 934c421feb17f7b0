"""The store's refusals in the API's words: 404 ``session_not_found``, 409 ``step_in_progress`` and
``lease_lost`` (both with Retry-After), 410 ``session_unreadable`` (a snapshot another version of the
service wrote), shared by the native routes and TEACh's."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from agent.snapshot import SnapshotError
from app.errors import LEASE_LOST, SESSION_NOT_FOUND, SESSION_UNREADABLE, STEP_IN_PROGRESS, ApiError
from app.redis_store import LeaseLost
from app.store import SessionBusy, SessionNotFound


def session_not_found(session_id: str) -> ApiError:
    return ApiError(
        404,
        SESSION_NOT_FOUND,
        f"no session {session_id!r} (never created, deleted, evicted after being idle past the TTL, or made "
        "with another API key)",
    )


@contextmanager
def store_errors_as_api_errors(session_id: str, lock_timeout_s: float) -> Iterator[None]:
    """The store's refusals as the API's: 404, 409 ``step_in_progress``, 409 ``lease_lost``."""
    try:
        yield
    except SessionNotFound as error:
        raise session_not_found(session_id) from error
    except SessionBusy as error:
        raise ApiError(
            409,
            STEP_IN_PROGRESS,
            f"session {session_id!r} is busy with another request for over {lock_timeout_s} s; "
            "retry when it has answered",
            headers={"Retry-After": "1"},
        ) from error
    except SnapshotError as error:
        raise ApiError(
            410,
            SESSION_UNREADABLE,
            f"session {session_id!r} was stored in a form this version of the service does not read "
            f"({error}); start a new session",
        ) from error
    except LeaseLost as error:
        raise ApiError(
            409, LEASE_LOST, f"{error}; send the request again", headers={"Retry-After": "1"}
        ) from error
