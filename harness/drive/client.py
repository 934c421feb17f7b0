"""A typed HTTP client of the service's native API (DESIGN.md §4), as a simulator harness uses it.

The harness talks to the agent only through this client: it never imports ``app``, ``agent`` or ``models``.
Frames are sent as AI2-THOR provides them to a TEACh runner: RGB as PNG (or JPEG), depth as a 16-bit PNG of
millimetres (or raw float32 metres) and, for oracle perception, instance ids as a 16-bit PNG with an
``{id: object type}`` legend; by default base64 in JSON, or as file parts of a multipart form. Where the
service is near (the same host, a fast link), ``ARRAY_FRAMES`` sends the arrays themselves (``.npy`` RGB
and instance ids, raw float32 depth) as file parts: nothing to compress here or to decode there.

``TeachRemoteModel`` speaks the other protocol the service serves: TEACh's ``RemoteModel`` forms (JPEG frames
only), as TEACh's own inference runner sends them.
"""

from __future__ import annotations

import base64
import io
import json
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from types import TracebackType
from typing import Any, Literal, Self

import cv2
import httpx
import numpy as np
from PIL import Image

from harness.render.renderer import Frame
from harness.world.model import AgentState

MILLIMETRES_PER_METRE = 1000.0
PNG_COMPRESSION = 1
"""cv2 PNG level 0-9: 1 keeps encoding at a few ms per 300x300 frame; the bytes stay lossless."""

RgbFormat = Literal["png", "jpeg", "npy"]
DepthEncoding = Literal["png16_mm", "float32_m"]
SegmentationFormat = Literal["png16", "npy"]
Transport = Literal["json", "multipart"]


@dataclass(frozen=True)
class FrameEncoding:
    """How a frame travels to the step route."""

    rgb_format: RgbFormat = "png"  # png: lossless; jpeg: what TEACh's RemoteModel sends; npy: the array
    jpeg_quality: int = 90  # 0-100, only for rgb_format "jpeg"
    depth: DepthEncoding = "png16_mm"  # 16-bit PNG of millimetres, or little-endian float32 metres
    segmentation: SegmentationFormat = "png16"  # instance ids as a 16-bit PNG, or the array as .npy
    transport: Transport = "json"  # base64 in a JSON body, or file parts of multipart/form-data
    send_rgb: bool = True  # oracle perception reads only depth + segmentation; AI2-THOR always has RGB
    send_oracle: bool = True  # depth + instance segmentation and its legend (what oracle perception reads)

    def __post_init__(self) -> None:
        if not 1 <= self.jpeg_quality <= 100:
            raise ValueError(f"jpeg_quality must lie in 1..100, got {self.jpeg_quality}")
        if not (self.send_rgb or self.send_oracle):
            raise ValueError(
                "a frame needs rgb or the oracle channels: send_rgb and send_oracle are both off"
            )


ARRAY_FRAMES = FrameEncoding(rgb_format="npy", depth="float32_m", segmentation="npy", transport="multipart")
"""Frames as arrays in file parts: about 0.9 MB a 300x300 step (against 0.23 MB of PNGs in base64), and
neither side compresses or decodes (the service's decoding took 2.2 ms of PNGs, 0.3 ms of arrays)."""


class ServiceError(Exception):
    """A non-2xx answer of the service, with its ``{"error", "detail"}`` body."""

    def __init__(self, status: int, error: str, detail: str, retry_after_s: float | None = None) -> None:
        # every argument, so it pickles across eval worker processes
        super().__init__(status, error, detail, retry_after_s)
        self.status = status
        self.error = error
        self.detail = detail
        self.retry_after_s = retry_after_s  # the answer's Retry-After, seconds

    def __str__(self) -> str:
        return f"HTTP {self.status} {self.error}: {self.detail}"


def pose_of(agent: AgentState) -> dict[str, float]:
    """The request's ``pose`` (world frame) from the simulator's agent, as AI2-THOR metadata reports it."""
    return {"x": agent.x, "z": agent.z, "yaw": float(agent.yaw % 360), "horizon": float(agent.horizon)}


def encode_npy(array: np.ndarray) -> bytes:
    """An array as a ``.npy`` file (its header says dtype and shape; nothing is pickled)."""
    buffer = io.BytesIO()
    np.save(buffer, np.ascontiguousarray(array), allow_pickle=False)
    return buffer.getvalue()


def encode_rgb(rgb: np.ndarray, fmt: RgbFormat = "png", jpeg_quality: int = 90) -> bytes:
    """uint8 [H, W, 3] RGB as PNG, JPEG or .npy bytes."""
    if fmt == "npy":
        return encode_npy(rgb.astype(np.uint8, copy=False))
    bgr = cv2.cvtColor(np.ascontiguousarray(rgb), cv2.COLOR_RGB2BGR)
    if fmt == "jpeg":
        ok, data = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, jpeg_quality])
    else:
        ok, data = cv2.imencode(".png", bgr, [cv2.IMWRITE_PNG_COMPRESSION, PNG_COMPRESSION])
    if not ok:
        raise ValueError(f"could not encode an rgb frame of shape {rgb.shape} as {fmt}")
    return data.tobytes()


def encode_uint16_png(pixels: np.ndarray) -> bytes:
    """A one-channel 16-bit PNG; values must already lie in 0..65535."""
    ok, data = cv2.imencode(".png", pixels.astype(np.uint16), [cv2.IMWRITE_PNG_COMPRESSION, PNG_COMPRESSION])
    if not ok:
        raise ValueError(f"could not encode a uint16 image of shape {pixels.shape}")
    return data.tobytes()


def encode_depth(depth_m: np.ndarray, encoding: DepthEncoding = "png16_mm") -> bytes:
    """float32 [H, W] metres (0 = no reading) as a 16-bit millimetre PNG or raw float32 metres."""
    if encoding == "float32_m":
        return np.ascontiguousarray(depth_m, dtype="<f4").tobytes()
    millimetres = np.clip(np.rint(depth_m * MILLIMETRES_PER_METRE), 0, np.iinfo(np.uint16).max)
    return encode_uint16_png(millimetres)


def encode_instances(instances: np.ndarray, fmt: SegmentationFormat = "png16") -> bytes:
    """int32 [H, W] instance ids as a 16-bit PNG or a uint16 .npy (the service's segmentation input)."""
    if instances.size and (instances.min() < 0 or instances.max() > np.iinfo(np.uint16).max):
        raise ValueError(f"instance ids must lie in 0..65535, got {instances.min()}..{instances.max()}")
    if fmt == "npy":
        return encode_npy(instances.astype(np.uint16))
    return encode_uint16_png(instances)


def observation_parts(frame: Frame, encoding: FrameEncoding) -> dict[str, bytes]:
    """The encoded images of one frame, by the step request's field names."""
    parts: dict[str, bytes] = {}
    if encoding.send_oracle:
        parts["depth"] = encode_depth(frame.depth, encoding.depth)
        if frame.depth_uncertainty is not None:
            parts["depth_uncertainty"] = encode_depth(frame.depth_uncertainty, encoding.depth)
        parts["segmentation"] = encode_instances(frame.instances, encoding.segmentation)
    if encoding.send_rgb:
        if frame.rgb is None:
            raise ValueError("send_rgb is set but the frame was rendered without rgb")
        parts["rgb"] = encode_rgb(frame.rgb, encoding.rgb_format, encoding.jpeg_quality)
    return parts


def _form_value(value: object) -> str:
    """A multipart text field: JSON for booleans and objects (pose, legend), plain text otherwise."""
    if isinstance(value, str):
        return value
    if isinstance(value, int) and not isinstance(value, bool):
        return str(value)
    return json.dumps(value)


def _file_name(field: str, encoding: FrameEncoding) -> str:
    if field == "rgb":
        return {"jpeg": "rgb.jpg", "npy": "rgb.npy", "png": "rgb.png"}[encoding.rgb_format]
    if field in ("depth", "depth_uncertainty") and encoding.depth == "float32_m":
        return f"{field}.f32"
    if field == "segmentation" and encoding.segmentation == "npy":
        return "segmentation.npy"
    return f"{field}.png"


def _error_of(response: httpx.Response) -> ServiceError:
    retry_after = response.headers.get("Retry-After")
    wait = float(retry_after) if retry_after is not None and retry_after.isdigit() else None
    try:
        body = response.json()
        return ServiceError(response.status_code, str(body["error"]), str(body["detail"]), wait)
    except (ValueError, KeyError, TypeError):
        return ServiceError(response.status_code, "unexpected_response", response.text[:500], wait)


RETRYABLE_CODES: frozenset[str] = frozenset({"step_in_progress", "lease_lost", "overloaded", "not_ready"})
"""Refusals that change nothing and pass: the session is busy, a worker's lease lapsed, the service is loaded
or starting. A step with its index can be sent again after them (the service answers a repeated index with
the answer it already gave)."""


class _HttpOwner:
    """Owns one httpx client and closes it with itself: use as a context manager or call ``close()``."""

    _http: httpx.Client

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self, kind: type[BaseException] | None, error: BaseException | None, trace: TracebackType | None
    ) -> None:
        self.close()

    def close(self) -> None:
        self._http.close()


@dataclass(frozen=True)
class RetryPolicy:
    """How long an idempotent request (a step with its index) keeps being sent again when the connection
    fails (a worker process died: the service's supervisor starts another, and the session continues from
    the shared store) or the answer is a passing refusal (``RETRYABLE_CODES``)."""

    give_up_after_s: float = 60.0  # a worker killed mid-step holds its sessions for up to the lease (6 s)
    first_wait_s: float = 0.05
    longest_wait_s: float = 2.0


class AgentClient(_HttpOwner):
    """One connection pool to a running service; use as a context manager or call ``close()``."""

    def __init__(
        self,
        base_url: str,
        timeout: float = 30.0,
        encoding: FrameEncoding | None = None,
        *,
        http: httpx.Client | None = None,
        retry: RetryPolicy | None = None,
    ) -> None:
        """``http``: a client to send through instead of a new pool (FastAPI's TestClient, or one without
        keep-alive to spread requests over worker processes); ``retry``: None sends each request once."""
        self.base_url = base_url.rstrip("/")
        self.encoding = encoding or FrameEncoding()
        self.retry = retry
        self.retried = 0  # requests sent again under ``retry``
        self._http = http or httpx.Client(base_url=self.base_url, timeout=timeout)

    def _send(self, method: str, path: str, **kwargs: Any) -> httpx.Response:
        response = self._http.request(method, path, **kwargs)
        if response.status_code >= 400:
            raise _error_of(response)
        return response

    # ---- service ------------------------------------------------------------------------------------

    def health(self) -> dict[str, Any]:
        """``GET /healthz``: liveness and version."""
        return dict(self._send("GET", "/healthz").json())

    def ready(self) -> dict[str, Any]:
        """``GET /readyz``: raises ServiceError 503 while the service is starting."""
        return dict(self._send("GET", "/readyz").json())

    # ---- sessions -----------------------------------------------------------------------------------

    def create_session(self, payload: Mapping[str, Any]) -> dict[str, Any]:
        """``POST /v1/sessions`` with a SessionCreate body; returns the SessionPublic (with the plan)."""
        return dict(self._send("POST", "/v1/sessions", json=dict(payload)).json())

    def get_session(self, session_id: str) -> dict[str, Any]:
        return dict(self._send("GET", f"/v1/sessions/{session_id}").json())

    def add_utterance(self, session_id: str, speaker: str, text: str) -> dict[str, Any]:
        body = {"speaker": speaker, "text": text}
        return dict(self._send("POST", f"/v1/sessions/{session_id}/utterances", json=body).json())

    def delete(self, session_id: str) -> None:
        self._send("DELETE", f"/v1/sessions/{session_id}")

    def trace(self, session_id: str, since: int | None = None) -> list[dict[str, Any]]:
        """``GET .../trace``: the session's ndjson trace, one dict per step."""
        params = {"since": since} if since is not None else None
        text = self._send("GET", f"/v1/sessions/{session_id}/trace", params=params).text
        return [json.loads(line) for line in text.splitlines() if line.strip()]

    def map_png(self, session_id: str) -> bytes:
        """``GET .../map.png``: the agent's semantic map as a PNG."""
        return self._send("GET", f"/v1/sessions/{session_id}/map.png").content

    # ---- steps --------------------------------------------------------------------------------------

    def step(
        self,
        session_id: str,
        frame: Frame,
        *,
        pose: Mapping[str, float] | None = None,
        last_action_success: bool | None = None,
        step_index: int | None = None,
        encoding: FrameEncoding | None = None,
    ) -> dict[str, Any]:
        """``POST .../step`` with one frame; returns the StepResult (action, x, y, subgoal, plan, done...)."""
        chosen = encoding or self.encoding
        parts = observation_parts(frame, chosen)
        fields: dict[str, Any] = {}
        if chosen.send_oracle:
            fields["depth_encoding"] = chosen.depth
            fields["segmentation_legend"] = {str(k): v for k, v in frame.legend.items()}
            if not frame.instance_ids_persistent:
                fields["segmentation_ids_persistent"] = False
        if pose is not None:
            fields["pose"] = dict(pose)
        if last_action_success is not None:
            fields["last_action_success"] = last_action_success
        if step_index is not None:
            fields["step"] = step_index
        path = f"/v1/sessions/{session_id}/step"
        if chosen.transport == "multipart":
            form = {name: _form_value(value) for name, value in fields.items()}
            files = {name: (_file_name(name, chosen), data) for name, data in parts.items()}
            return dict(self._idempotent(step_index, "POST", path, data=form, files=files).json())
        body = {**fields, **{name: base64.b64encode(data).decode("ascii") for name, data in parts.items()}}
        return dict(self._idempotent(step_index, "POST", path, json=body).json())

    def _idempotent(self, step_index: int | None, method: str, path: str, **kwargs: Any) -> httpx.Response:
        """Send a step; with its index and a retry policy, send it again after a failed connection or a
        passing refusal until it is answered or the policy gives up."""
        if self.retry is None or step_index is None:
            return self._send(method, path, **kwargs)
        deadline = time.monotonic() + self.retry.give_up_after_s
        wait = self.retry.first_wait_s
        while True:
            try:
                return self._send(method, path, **kwargs)
            except httpx.TransportError:
                if time.monotonic() + wait > deadline:
                    raise
            except ServiceError as error:
                if error.error not in RETRYABLE_CODES or time.monotonic() + wait > deadline:
                    raise
                wait = max(wait, min(error.retry_after_s or 0.0, self.retry.longest_wait_s))
            self.retried += 1
            time.sleep(wait)
            wait = min(wait * 2, self.retry.longest_wait_s)


# ---- TEACh's RemoteModel -------------------------------------------------------------------------------

TEACH_PREDICT_PATH = "/get_next_action"
TEACH_START_EDH_PATH = "/start_new_edh_instance"
TEACH_TEST_PATH = "/test"


def _pil_jpeg(image: Image.Image) -> io.BytesIO:
    """What RemoteModel does with each frame: ``image.save(buffer, "jpeg")`` (Pillow's default quality 75)."""
    buffer = io.BytesIO()
    image.save(buffer, "jpeg")
    buffer.seek(0)
    return buffer


def _without_none(data: Mapping[str, str | None]) -> dict[str, str]:
    """The form fields ``requests`` sends for a ``data`` dict: it leaves out keys whose value is None."""
    return {key: value for key, value in data.items() if value is not None}


class TeachRemoteModel(_HttpOwner):
    """TEACh's ``RemoteModel`` client (``teach/inference/remote_model.py``), request for request.

    The same URLs, form fields, JSON encodings, file names and content types as TEACh's class; only the HTTP
    library differs (httpx here, ``requests`` there), with ``requests``' two habits reproduced: a field whose
    value is None is left out (so ``prev_action`` is absent on the first step, and ``edh_name`` when not
    given), and a form without files is sent urlencoded rather than multipart. Errors raise ServiceError
    where RemoteModel raises its RemoteModelException (TEACh's runner ends the instance either way).
    """

    def __init__(self, base_url: str, timeout: float = 120.0, http: httpx.Client | None = None) -> None:
        """``http``: a client to send through instead of a new one (FastAPI's TestClient in tests)."""
        self.base_url = base_url.rstrip("/")
        self._http = http or httpx.Client(base_url=self.base_url, timeout=timeout)

    def _post(self, path: str, data: Mapping[str, str | None], files: Any) -> httpx.Response:
        response = self._http.post(path, data=_without_none(data), files=files)
        if response.status_code != 200:
            raise _error_of(response)
        return response

    def test_connection(self) -> bool:
        return self._http.get(TEACH_TEST_PATH).status_code == 200

    def start_new_edh_instance(
        self,
        edh_instance: Mapping[str, Any],
        edh_history_images: Sequence[Image.Image] | None,
        edh_name: str | None = None,
    ) -> dict[str, Any]:
        """One ``edh_history_images`` JPEG per image, named ``history<i>``; returns the service's answer
        (RemoteModel only checks the status and returns True)."""
        images = [
            ("edh_history_images", (f"history{index}", _pil_jpeg(image), "image/jpeg"))
            for index, image in enumerate(edh_history_images or ())
        ]
        data = {"edh_name": edh_name, "edh_instance": json.dumps(edh_instance)}
        return dict(self._post(TEACH_START_EDH_PATH, data, images).json())

    def get_next_action(
        self,
        img: Image.Image,
        edh_instance: Mapping[str, Any],
        prev_action: Mapping[str, Any] | None,
        img_name: str | None = None,
        edh_name: str | None = None,
    ) -> tuple[str | None, list[float] | None]:
        """(action, obj_relative_coord as [row, column]); ``prev_action`` None or empty on the first step."""
        data = {
            "img_name": img_name,
            "edh_name": edh_name,
            "prev_action": json.dumps(prev_action) if prev_action else None,
            "edh_instance": json.dumps(edh_instance),
        }
        files = {"img": (img_name, _pil_jpeg(img), "image/jpeg")}
        answer = self._post(TEACH_PREDICT_PATH, data, files).json()
        return answer.get("action"), answer.get("obj_relative_coord")
