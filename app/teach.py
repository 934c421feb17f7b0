"""TEACh's ``RemoteModel`` protocol over the agent: one session per EDH instance, RGB frames only.

TEACh's inference runner (``teach_inference --model_module teach.inference.remote_model --model_class
RemoteModel``) drives a model over HTTP with two form posts (``../shared/data/teach/FORMATS.md``,
"Inference protocol"; TEACh's ``teach/inference/remote_model.py``):

- ``POST /start_new_edh_instance``: text fields ``edh_name`` (the instance file's path) and
  ``edh_instance`` (the EDH instance as a JSON string), and one ``edh_history_images`` JPEG file per
  history action (none when the runner reads images itself; then the body is urlencoded, not multipart).
- ``POST /get_next_action``: text fields ``img_name``, ``edh_name``, ``edh_instance`` (JSON) and
  ``prev_action`` (JSON ``{"action", "obj_relative_coord"}``; absent on the first step, because the
  ``requests`` library drops fields whose value is None), and the frame as the JPEG file ``img``. The
  answer is ``{"action", "obj_relative_coord": [row, column]}``: TEACh's runner reads index 0 as y.

Each EDH instance gets a session in mode ``edh`` with the model planner (it plans from the dialogue
history) and learned perception (TEACh sends RGB only, no pose, and never says whether the last action
worked). The history's actions set the agent's belief and their frames are replayed into the map. The
camera is the frames' own size at TEACh's 90°: the history images' size, or, without history images, the
first frame's (the session is then rebuilt once, before its first step, if that frame is not 900x900).
A repeated ``img_name`` gets the same answer again; a ``prev_action`` that is not the last answer is 409.
"""

from __future__ import annotations

import json
import uuid
from collections.abc import Mapping
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any, cast

from fastapi import Request
from pydantic import ValidationError
from starlette.datastructures import UploadFile
from starlette.exceptions import HTTPException

from agent.session import AgentSession, StepDecision
from app.error_handlers import validation_detail
from app.errors import (
    EDH_INSTANCE_NOT_STARTED,
    MALFORMED_FORM,
    SESSION_NOT_FOUND,
    STEP_IN_PROGRESS,
    STEP_OUT_OF_ORDER,
    UNSUPPORTED_MEDIA_TYPE,
    VALIDATION_ERROR,
    ApiError,
)
from app.limits import check_history_length
from app.metrics import ServiceMetrics
from app.observation import image_size, rgb_observation
from app.ownership import Caller, owner_cap, too_many_sessions
from app.schemas import CameraSpec, SessionCreate, TeachAction, TeachPrevAction, TeachStarted
from app.session_builder import build_session
from app.settings import Settings
from app.step_run import StepRules, run_step
from app.store import SessionNotFound, SessionStore, StoredSession, StoreFull
from app.store_errors import store_errors_as_api_errors
from app.views import plan_out
from symbolic.ontology import Ontology
from symbolic.thor import OBJECT_ACTIONS, TEACH_HFOV_DEG, TEACH_IMAGE_SIDE

START_EDH_PATH = "/start_new_edh_instance"
HISTORY_FIELD = "edh_history_images"
FORM_TYPES = ("multipart/form-data", "application/x-www-form-urlencoded")
MAX_FORM_FIELDS = 64  # text fields per TEACh request (it sends at most four)
MAX_TEXT_PART_BYTES = 64 * 1024 * 1024  # an edh_instance JSON with a long game's interactions and state diffs


# ---- the form ----------------------------------------------------------------------------------------


@dataclass(frozen=True)
class TeachForm:
    """A TEACh request's form: text fields and file parts, by name, in the order sent."""

    texts: dict[str, list[str]]
    files: dict[str, list[bytes]]

    def text(self, name: str) -> str | None:
        """The field's value; None when absent or blank (TEACh's "no value")."""
        values = self.texts.get(name, [])
        if len(values) > 1:
            raise ApiError(422, VALIDATION_ERROR, f"{name}: sent {len(values)} times; send it once")
        value = values[0] if values else None
        return value if value is not None and value.strip() else None

    def file(self, name: str) -> bytes | None:
        """A file part's bytes. A part sent without a file name (``requests`` does so when RemoteModel's
        ``img_name`` is None) arrives as text, decoded as Latin-1 (image bytes are never valid UTF-8), and
        is turned back into the same bytes."""
        parts = self.file_list(name)
        if len(parts) > 1:
            raise ApiError(422, VALIDATION_ERROR, f"{name}: sent {len(parts)} files; send one")
        return parts[0] if parts else None

    def file_list(self, name: str) -> list[bytes]:
        return [*self.files.get(name, []), *(_text_part_bytes(t) for t in self.texts.get(name, []))]

    def json_object(self, name: str, *, required: bool) -> dict[str, Any] | None:
        """A text field holding a JSON object (``edh_instance``); 422 naming the field otherwise."""
        text = self.text(name)
        if text is None:
            if required:
                raise ApiError(
                    422, VALIDATION_ERROR, f"{name}: field required (a JSON object, as a form field)"
                )
            return None
        try:
            value = json.loads(text)
        except json.JSONDecodeError as error:
            raise ApiError(422, VALIDATION_ERROR, f"{name}: is not valid JSON ({error})") from error
        if value is None and not required:
            return None
        if not isinstance(value, dict):
            raise ApiError(
                422, VALIDATION_ERROR, f"{name}: expected a JSON object, got {type(value).__name__}"
            )
        return cast(dict[str, Any], value)


def _text_part_bytes(text: str) -> bytes:
    """The bytes of a part that arrived as text: Starlette decodes bytes that are not UTF-8 as Latin-1, which
    encoding back restores exactly; text that was UTF-8 goes back to its UTF-8 bytes (then it is no image,
    and decoding it says so)."""
    try:
        return text.encode("latin-1")
    except UnicodeEncodeError:
        return text.encode("utf-8")


async def read_teach_form(request: Request, settings: Settings) -> TeachForm:
    """The request's form (multipart, or urlencoded when ``requests`` has no file to send); 415 for other
    bodies, 400 for a malformed form, 413 for more history images than the settings allow."""
    content_type = request.headers.get("content-type", "").split(";")[0].strip().lower()
    if content_type not in FORM_TYPES:
        raise ApiError(
            415,
            UNSUPPORTED_MEDIA_TYPE,
            f"this TEACh route reads a form ({' or '.join(FORM_TYPES)}), as TEACh's RemoteModel sends; got "
            f"{content_type or 'no content type'}",
        )
    texts: dict[str, list[str]] = {}
    files: dict[str, list[bytes]] = {}
    try:
        async with request.form(
            max_files=settings.max_edh_history_frames + 1,
            max_fields=MAX_FORM_FIELDS,
            max_part_size=MAX_TEXT_PART_BYTES,
        ) as form:
            for name, value in form.multi_items():
                if isinstance(value, UploadFile):
                    files.setdefault(name, []).append(await value.read())
                else:
                    texts.setdefault(name, []).append(value)
    except HTTPException as error:  # Starlette's MultiPartException, as a 400
        if "Too many files" in str(error.detail):
            raise ApiError(
                413,
                MALFORMED_FORM,
                f"more than {settings.max_edh_history_frames} files in one request "
                "(setting JARVIS_MAX_EDH_HISTORY_FRAMES)",
            ) from error
        raise ApiError(400, MALFORMED_FORM, f"the form cannot be read: {error.detail}") from error
    return TeachForm(texts=texts, files=files)


# ---- one session per EDH instance ------------------------------------------------------------------------


TEACH_NOTES = "teach"
"""Key of the TEACh protocol's state in the stored session's notes (``StoredSession.meta``), kept with the
session's snapshot so a retried frame gets its answer from any worker."""


@dataclass
class TeachEpisode:
    """What the TEACh layer keeps about one EDH instance beside its session (JSON in the session's notes)."""

    edh_name: str
    pending: SessionCreate | None
    """The session's request while its camera may still follow the first frame (no history images)."""
    last_img_name: str | None = None
    """The frame the session last answered; the same name again is a retry (the session's last answer)."""

    def notes(self) -> dict[str, Any]:
        return {
            "edh_name": self.edh_name,
            "pending": self.pending.model_dump(mode="json") if self.pending is not None else None,
            "last_img_name": self.last_img_name,
        }

    @classmethod
    def from_notes(cls, notes: Mapping[str, Any]) -> TeachEpisode:
        pending = notes.get("pending")
        return cls(
            edh_name=str(notes["edh_name"]),
            pending=SessionCreate.model_validate(pending) if pending is not None else None,
            last_img_name=notes.get("last_img_name"),
        )


def _edh_name(form: TeachForm, edh_instance: Mapping[str, Any] | None) -> str:
    """``edh_name`` as sent, else the instance's ``instance_id`` (RemoteModel drops a None edh_name)."""
    name = form.text("edh_name")
    if name is not None:
        return name
    instance_id = (edh_instance or {}).get("instance_id")
    if isinstance(instance_id, str) and instance_id.strip():
        return instance_id
    raise ApiError(
        422,
        VALIDATION_ERROR,
        "edh_name: field required (or an edh_instance with an instance_id) to tell EDH instances apart",
    )


def _dialogue(edh_instance: Mapping[str, Any]) -> list[dict[str, str]]:
    """TEACh's ``dialog_history_cleaned`` (else ``dialog_history``): ``[speaker, utterance]`` pairs; blank
    utterances are left out (nothing was said)."""
    key = "dialog_history_cleaned" if edh_instance.get("dialog_history_cleaned") else "dialog_history"
    turns = edh_instance.get(key)
    if turns is None:
        raise ApiError(422, VALIDATION_ERROR, "edh_instance.dialog_history: field required")
    if not isinstance(turns, list):
        raise ApiError(422, VALIDATION_ERROR, f"edh_instance.{key}: expected a list of [speaker, utterance]")
    dialogue = []
    for index, turn in enumerate(turns):
        if not (isinstance(turn, list | tuple) and len(turn) == 2 and all(isinstance(t, str) for t in turn)):
            raise ApiError(
                422,
                VALIDATION_ERROR,
                f"edh_instance.{key}[{index}]: expected [speaker, utterance] strings, got {str(turn)[:80]}",
            )
        if turn[1].strip():
            dialogue.append({"speaker": turn[0], "text": turn[1]})
    return dialogue


def _renamed(detail: str) -> str:
    """A SessionCreate field path in the words of the TEACh request."""
    for native, teach in (
        ("history.actions", "edh_instance.driver_action_history"),
        ("dialogue", "edh_instance.dialog_history"),
    ):
        detail = detail.replace(native, teach)
    return detail


def edh_session_request(edh_instance: Mapping[str, Any], camera: CameraSpec) -> SessionCreate:
    """The native session request for an EDH instance: mode edh, the model planner, learned perception."""
    actions = edh_instance.get("driver_action_history", [])
    if not isinstance(actions, list):
        raise ApiError(
            422, VALIDATION_ERROR, "edh_instance.driver_action_history: expected a list of actions"
        )
    try:
        return SessionCreate.model_validate(
            {
                "mode": "edh",
                "camera": camera.model_dump(),
                "perception": "learned",
                "planner": "model",
                "dialogue": _dialogue(edh_instance),
                "history": {"actions": actions},
            }
        )
    except ValidationError as error:
        raise ApiError(422, VALIDATION_ERROR, _renamed(validation_detail(error.errors()))) from error


def _teach_camera(width: int, height: int) -> CameraSpec:
    return CameraSpec(width=width, height=height, hfov_deg=TEACH_HFOV_DEG)


def _build(
    request: SessionCreate,
    frames: list[bytes] | None,
    settings: Settings,
    ontology: Ontology,
    session_id: str,
) -> AgentSession:
    try:
        return build_session(
            request,
            settings,
            ontology,
            session_id=session_id,
            now=datetime.now(UTC),
            history_frames=frames,
            history_frames_field=HISTORY_FIELD,
        )
    except ApiError as error:
        raise ApiError(error.status, error.code, _renamed(error.detail)) from error


def _store_evicting_finished(
    session: AgentSession,
    episode: TeachEpisode,
    store: SessionStore,
    caller: Caller,
    settings: Settings,
) -> None:
    """Store the session; when the store (or the caller's share) is full, first drop the caller's finished
    TEACh sessions, oldest first (the runner never deletes them: after Stop, or its 30 failed actions, it
    just starts the next instance)."""
    stored = StoredSession(session, caller.owner, {TEACH_NOTES: episode.notes()})
    cap = owner_cap(caller, settings)
    try:
        store.create(stored, owner_cap=cap)
        return
    except StoreFull:
        pass
    for name, session_id in store.names(caller.owner):
        if store.finished(session_id):
            store.unbind_name(caller.owner, name)
            _delete_quietly(store, session_id, caller.owner)
    try:
        store.create(stored, owner_cap=cap)
    except StoreFull as error:
        raise too_many_sessions(error, settings) from error


def _delete_quietly(store: SessionStore, session_id: str, owner: str | None) -> None:
    try:
        store.delete(session_id, owner)
    except SessionNotFound:
        return


def start_edh_instance(
    form: TeachForm, settings: Settings, store: SessionStore, ontology: Ontology, caller: Caller
) -> TeachStarted:
    """A new session for the instance, replacing the one an earlier start of the same name (by the same
    API key) made; another key's instance of the same name is another session."""
    edh_instance = form.json_object("edh_instance", required=True)
    assert edh_instance is not None
    name = _edh_name(form, edh_instance)
    actions = edh_instance.get("driver_action_history")
    if isinstance(actions, list):  # before any work: validating 200k actions alone takes a CPU-second
        check_history_length(len(actions), settings, "edh_instance.driver_action_history")
    frames = form.file_list(HISTORY_FIELD)
    if frames:
        width, height = image_size(frames[0], f"{HISTORY_FIELD}[0]")
    else:
        width = height = TEACH_IMAGE_SIDE
    request = edh_session_request(edh_instance, _teach_camera(width, height))
    session = _build(request, frames or None, settings, ontology, session_id=uuid.uuid4().hex)
    episode = TeachEpisode(name, pending=None if frames else request)
    _store_evicting_finished(session, episode, store, caller, settings)
    replaced = store.bind_name(caller.owner, name, session.session_id)
    if replaced is not None and replaced != session.session_id:
        _delete_quietly(store, replaced, caller.owner)
    return TeachStarted(
        success=True,
        edh_name=name,
        session_id=session.session_id,
        history_frames=len(frames),
        plan=plan_out(session),
    )


def _prev_action(form: TeachForm) -> TeachPrevAction | None:
    """``prev_action``: absent, blank or JSON null on the first step; else what the runner executed."""
    text = form.text("prev_action")
    if text is None:
        return None
    try:
        value = json.loads(text)
    except json.JSONDecodeError as error:
        raise ApiError(422, VALIDATION_ERROR, f"prev_action: is not valid JSON ({error})") from error
    if value is None or value == {}:
        return None
    try:
        return TeachPrevAction.model_validate(value)
    except ValidationError as error:
        detail = validation_detail([{**e, "loc": ("prev_action", *e["loc"])} for e in error.errors()])
        raise ApiError(422, VALIDATION_ERROR, detail) from error


def _check_prev_action(prev: TeachPrevAction | None, session: AgentSession, name: str) -> None:
    """A ``prev_action`` sent must be the session's last answer (else the two disagree on where the episode
    is: a lost answer, or a client that skipped one). Leaving it out is always allowed: it tells nothing."""
    if prev is None:
        return
    last = session.last_decision
    if last is None:
        raise ApiError(
            409,
            STEP_OUT_OF_ORDER,
            f"prev_action {prev.action!r} was sent but EDH instance {name!r} has not answered yet; the first "
            "request of an instance carries no prev_action",
        )
    if prev.action != last.action:
        raise ApiError(
            409,
            STEP_OUT_OF_ORDER,
            f"prev_action {prev.action!r} is not the last answer of EDH instance {name!r} ({last.action!r})",
        )


def _adopt_frame_size(
    held: StoredSession, episode: TeachEpisode, size: tuple[int, int], settings: Settings, ontology: Ontology
) -> None:
    """Before the first step of a session started without history images, make its camera the frame's."""
    request = episode.pending
    if request is None or request.camera is None or (request.camera.width, request.camera.height) == size:
        return
    if held.session.step > 0:
        return
    resized = request.model_copy(update={"camera": _teach_camera(*size)})
    held.session = _build(resized, None, settings, ontology, session_id=held.session.session_id)
    episode.pending = resized


def _teach_action(decision: StepDecision) -> TeachAction:
    """A decision as TEACh's runner reads it: the click point row first (index 0 is y)."""
    coord = None
    if decision.action in OBJECT_ACTIONS and decision.x is not None and decision.y is not None:
        coord = [decision.y, decision.x]
    return TeachAction(action=decision.action, obj_relative_coord=coord)


def next_action(
    form: TeachForm,
    settings: Settings,
    store: SessionStore,
    ontology: Ontology,
    caller: Caller,
    metrics: ServiceMetrics,
) -> TeachAction:
    """The instance session's next action for this frame (see the module docstring for the rules)."""
    edh_instance = form.json_object("edh_instance", required=False)
    name = _edh_name(form, edh_instance)
    session_id = store.named(caller.owner, name)
    if session_id is None:
        raise ApiError(
            404,
            EDH_INSTANCE_NOT_STARTED,
            f"no EDH instance {name!r} was started (or its session expired); POST /start_new_edh_instance "
            "first, as TEACh's runner does before each instance",
        )
    img = form.file("img")
    if img is None:
        raise ApiError(422, VALIDATION_ERROR, "img: file required (the current frame as JPEG or PNG)")
    prev = _prev_action(form)
    img_name = form.text("img_name")
    timeout = settings.session_lock_timeout_s
    try:
        with (
            store_errors_as_api_errors(session_id, timeout),
            store.hold(session_id, caller.owner, timeout, write=True) as held,
        ):
            episode = TeachEpisode.from_notes(held.meta[TEACH_NOTES])
            if episode.pending is not None:
                _adopt_frame_size(held, episode, image_size(img, "img"), settings, ontology)
            rules = StepRules(
                repeats_last=lambda _, __: img_name is not None and img_name == episode.last_img_name,
                check_order=lambda session: _check_prev_action(prev, session, name),
                observe=lambda session: rgb_observation(img, session.spec.camera, ontology, "img"),
                field_names={"rgb": "img"},
            )
            run = run_step(held, rules, metrics)
            if not run.repeated:
                episode.pending = None
                episode.last_img_name = img_name
                held.meta[TEACH_NOTES] = episode.notes()
            return _teach_action(run.decision)
    except ApiError as error:
        if error.code == SESSION_NOT_FOUND:
            store.unbind_name(caller.owner, name)
            raise ApiError(
                404,
                EDH_INSTANCE_NOT_STARTED,
                f"the session of EDH instance {name!r} expired after {settings.session_ttl_s} s idle; start "
                "the instance again",
            ) from error
        if error.code == STEP_IN_PROGRESS:
            raise ApiError(
                409,
                STEP_IN_PROGRESS,
                f"EDH instance {name!r} is busy with another request for over {timeout} s; retry later",
                headers=error.headers,
            ) from error
        raise
