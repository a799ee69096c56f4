"""Record the robot's run to rotating MCAP files and serve it live to Foxglove, off the loop.

The control loop only *offers* messages (`Recorder.state`, `command`, `json`, `path`): each is
put on a bounded queue without waiting, and a full queue drops the message and counts it
(``dropped``), so recording can never block the loop. One writer thread converts the messages
to Foxglove's well-known schemas (`foxglove_convert`) and logs them on the channels of a private
`foxglove.Context`; the context's sinks are the open MCAP file and, if asked, the live WebSocket
server, so both get the same channels.

Files rotate when the open one reaches ``max_file_bytes`` or ``max_file_seconds`` of daemon time;
before a new file is opened the oldest recordings in the directory are deleted until the closed
ones plus a full new file fit in ``max_total_bytes``. Each new file starts with the latched state
(map, route, planned path, laser mount), so every file can be opened on its own.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
import queue
import re
import threading
import time
from collections import Counter
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import foxglove
import msgspec
import numpy as np
from foxglove.channels import (
    CompressedImageChannel,
    FrameTransformsChannel,
    GridChannel,
    LaserScanChannel,
    PosesInFrameChannel,
)
from foxglove.mcap import MCAPCompression, MCAPWriteOptions

from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import LaserScan
from interbot_core.occupancy_grid import OccupancyGrid
from interbot_core.topics import (
    TOPIC_SPECS,
    ImageMsg,
    JsonMessage,
    Odom,
    PlanMsg,
    PoseMsg,
    RouteMsg,
    Topic,
)
from robot_daemon.config import RecordingConfig
from robot_daemon.recording import foxglove_convert as fc
from robot_daemon.stack import DEFAULT_LASER_MOUNT

logger = logging.getLogger(__name__)

FILE_PATTERN = re.compile(
    r"^(?P<robot>[A-Za-z0-9_-]+)_(?P<stamp>\d{8}-\d{6})_(?P<seq>\d{4,})\.mcap$"
)
SIZE_CHECK_PERIOD = 4  # messages between two looks at the open file's size (a stat: ~2 µs)
CHUNK_BYTES = 512 * 1024  # MCAP chunk (uncompressed): the file grows in steps of about this

# Channel names: Foxglove's conventions (ROS-like topic paths).
TF, MAP, SCAN, ROUTE, PLANNED_PATH = "/tf", "/map", "/scan", "/route", "/planned_path"
CAMERA_JPEG = "/camera/image/compressed"
COMMANDS = "/commands"
JSON_STATE_TOPICS = {
    spec.topic: f"/{spec.topic.value}"
    for spec in TOPIC_SPECS.values()
    if not spec.command and not spec.binary
}
"""The link's JSON state topics (pose, odom, cmd_vel, mux, battery, route_progress, status, plan
...), each recorded as itself on ``/<topic>``."""


class RecorderError(RuntimeError):
    """The recorder cannot start (directory not writable, port taken, ...)."""


@dataclass(frozen=True)
class LiveServer:
    """Where the live Foxglove WebSocket server listens (port 0: the OS picks)."""

    host: str = "127.0.0.1"
    port: int = 8765
    tls_cert: bytes | None = field(default=None, repr=False)  # PEM; with tls_key: wss:// only
    tls_key: bytes | None = field(default=None, repr=False)  # PEM, PKCS#8

    def __post_init__(self) -> None:
        if (self.tls_cert is None) != (self.tls_key is None):
            raise ValueError("a TLS live server needs both a certificate and its key")


def ns(t: float) -> int:
    """Seconds -> integer nanoseconds (MCAP log time)."""
    return round(t * 1e9)


def is_message(value: object) -> bool:
    """A message instance: a msgspec Struct or a dataclass (not the class itself)."""
    return isinstance(value, msgspec.Struct) or (
        dataclasses.is_dataclass(value) and not isinstance(value, type)
    )


def message_dict(message: object) -> dict[str, Any]:
    """A message as a JSON-ready dict (tuples become lists, bytes are left out)."""
    if not is_message(message):
        raise TypeError(f"not a message: {message!r}")
    names = (
        message.__struct_fields__
        if isinstance(message, msgspec.Struct)
        else tuple(f.name for f in dataclasses.fields(message))  # type: ignore[arg-type]
    )
    out: dict[str, Any] = {}
    for name in names:
        value = getattr(message, name)
        if isinstance(value, bytes | np.ndarray):
            continue
        out[name] = jsonable(value)
    return out


def jsonable(value: Any) -> Any:
    """JSON-ready: tuples to lists, numpy scalars to Python, NaN/inf to null (JSON has neither)."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, tuple | list):
        return [jsonable(v) for v in value]
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, np.generic):
        return jsonable(value.item())
    if is_message(value):
        return message_dict(value)
    if hasattr(value, "value") and not isinstance(value, int | float | str | bool):
        return jsonable(value.value)  # enums
    return value


class McapRotation:
    """Names, rotates and prunes the MCAP files of one robot in one directory."""

    def __init__(
        self,
        config: RecordingConfig,
        robot_id: str,
        wall_clock: Callable[[], float] = time.time,
    ) -> None:
        self.config = config
        self.robot_id = robot_id
        self._wall_clock = wall_clock
        self._seq = 0
        if config.directory is None:
            raise RecorderError("recording: 'directory' must be a directory path")
        self.directory = Path(config.directory)
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise RecorderError(
                f"cannot create the recording directory {self.directory}: {exc.strerror}"
            ) from None
        if not self.directory.is_dir():
            raise RecorderError(f"recording directory {self.directory} is not a directory")

    def recordings(self) -> list[Path]:
        """This robot's recordings in the directory, oldest first."""
        files = []
        for path in self.directory.iterdir():
            m = FILE_PATTERN.match(path.name)
            if m and m["robot"] == self.robot_id:
                files.append((m["stamp"], int(m["seq"]), path))
        return [path for *_, path in sorted(files)]

    def next_path(self) -> Path:
        stamp = time.strftime("%Y%m%d-%H%M%S", time.gmtime(self._wall_clock()))
        self._seq += 1
        return self.directory / f"{self.robot_id}_{stamp}_{self._seq:04d}.mcap"

    def prune(self) -> list[Path]:
        """Delete the oldest recordings until they and one full new file fit under the cap."""
        deleted = []
        files = self.recordings()
        total = sum(_size(p) for p in files)
        while files and total + self.config.max_file_bytes > self.config.max_total_bytes:
            oldest = files.pop(0)
            total -= _size(oldest)
            with contextlib.suppress(FileNotFoundError):
                oldest.unlink()
            deleted.append(oldest)
            logger.info("recording cap: deleted %s", oldest.name)
        return deleted


def _size(path: Path) -> int:
    try:
        return path.stat().st_size
    except FileNotFoundError:
        return 0


_STOP = object()


class Recorder:
    """Takes the robot's messages without blocking; writes MCAP and/or serves Foxglove live.

    ``rotation`` records to rotating files in a directory; ``single_file`` to one file (a
    headless scenario); ``live`` starts the WebSocket server. ``epoch_offset`` [s] is added to
    daemon time for the messages' log times (the wall time at daemon time zero).
    """

    def __init__(
        self,
        robot_id: str,
        *,
        rotation: McapRotation | None = None,
        single_file: Path | None = None,
        live: LiveServer | None = None,
        epoch_offset: float = 0.0,
        queue_size: int = 2048,
        camera: bool = True,
        laser_mount: Pose2D | None = None,
    ) -> None:
        if rotation is not None and single_file is not None:
            raise ValueError("record to a rotating directory or to a single file, not both")
        self.robot_id = robot_id
        self.camera = camera
        self.epoch_offset = epoch_offset
        self._rotation = rotation
        self._single_file = single_file
        self._laser_mount = laser_mount or DEFAULT_LASER_MOUNT
        self._queue: queue.Queue[Any] = queue.Queue(maxsize=queue_size)
        self.dropped = 0
        self.dropped_by_kind: Counter[str] = Counter()
        self.written = 0
        self.errors = 0
        self._reported = (0, 0)  # (dropped, errors) when last reported to the station
        self.writer_cpu_s = 0.0  # [s] CPU time of the writer thread (conversion + writing)
        self.files: list[Path] = []
        self._context = foxglove.Context()
        self._channels: dict[str, Any] = {}
        self._writer: Any = None
        self._file_start: float | None = None  # daemon time of the open file's first message
        self._since_size_check = 0
        self._latched: dict[str, tuple[float, Any]] = {}  # channel -> (t, foxglove message)
        self._pose: Pose2D | None = None
        self._odom_seen = False
        self.server: Any = None
        if live is not None:
            try:
                self.server = foxglove.start_server(
                    name=f"interbot {robot_id}",
                    host=live.host,
                    port=live.port,
                    context=self._context,
                    tls_cert=live.tls_cert,
                    tls_key=live.tls_key,
                )
            except Exception as exc:  # the SDK raises its own types for bind errors
                raise RecorderError(
                    f"cannot serve Foxglove on {live.host}:{live.port}: {exc}"
                ) from None
            scheme = "wss" if live.tls_cert else "ws"
            logger.info("Foxglove live view on %s://%s:%d", scheme, live.host, self.port)
        self._chunk_bytes = CHUNK_BYTES
        if rotation is not None:  # several chunks per file, so the size check is not too coarse
            self._chunk_bytes = max(4096, min(CHUNK_BYTES, rotation.config.max_file_bytes // 16))
        try:
            self._open_first_file()
        except RecorderError:
            if self.server is not None:
                self.server.stop()
            raise
        self._thread = threading.Thread(target=self._run, name="recorder", daemon=True)
        self._thread.start()

    # ------------------------------------------------------------------ the loop's side

    def _offer(self, item: tuple[Any, ...]) -> None:
        try:
            self._queue.put_nowait(item)
        except queue.Full:
            self.dropped += 1
            self.dropped_by_kind[item[0]] += 1

    def state(self, topic: Topic, message: object, now: float) -> None:
        """A state message as published on the link (pose, scan, map, image, ...)."""
        if topic is Topic.IMAGE and not self.camera:
            return
        self._offer(("state", now, topic, message))

    def command(
        self, topic: Topic | str, message: object, now: float, source: str = "station"
    ) -> None:
        """A command the robot received: who (``source``) asked for what."""
        self._offer(("command", now, str(topic), message, source))

    def json(self, channel: str, data: Mapping[str, Any] | object, now: float) -> None:
        """Anything else, as JSON on ``channel`` (localisation, simulator truth, tasks ...)."""
        self._offer(("json", now, channel, data))

    @property
    def port(self) -> int | None:
        return int(self.server.port) if self.server is not None else None

    def stats(self) -> dict[str, Any]:
        return {
            "written": self.written,
            "dropped": self.dropped,
            "errors": self.errors,
            "queued": self._queue.qsize(),
            "writer_cpu_s": round(self.writer_cpu_s, 3),
            "files": [str(p) for p in self.files],
        }

    def health_report(self) -> str | None:
        """A line for the station when drops or write errors grew (then at each doubling), else None.

        Called by the loop (cheap: two integer reads); recording that loses data says so.
        """

        def due(count: int, last: int) -> bool:
            return count > 0 and count >= 2 * last

        if not (due(self.dropped, self._reported[0]) or due(self.errors, self._reported[1])):
            return None
        self._reported = (self.dropped, self.errors)
        return (
            f"recording is losing data: {self.dropped} messages dropped (writer behind), "
            f"{self.errors} write errors; files in {self.files[-1].parent if self.files else '-'}"
        )

    def flush(self, timeout: float = 10.0) -> bool:
        """Wait until everything offered so far is written (tests, the end of a scenario)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self._queue.unfinished_tasks == 0:
                return True
            time.sleep(0.005)
        return False

    def close(self) -> None:
        """Write what is queued, finish the file, stop the server. Idempotent."""
        if not self._thread.is_alive():
            return
        self._queue.put(_STOP)
        self._thread.join(timeout=30.0)
        if self._writer is not None:
            self._writer.close()
            self._writer = None
        if self.server is not None:
            self.server.stop()
        if self.dropped:
            logger.warning(
                "recorder dropped %d messages (%s)", self.dropped, dict(self.dropped_by_kind)
            )
        logger.info("recorder closed: %s", self.stats())

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ writer thread

    def _run(self) -> None:
        last_warned = 0
        while True:
            item = self._queue.get()
            try:
                if item is _STOP:
                    return
                start = time.thread_time()
                try:
                    self._write(item)
                    self.written += 1
                except Exception:  # one bad message must not end the recording
                    self.errors += 1
                    if self.errors <= 5:
                        logger.exception("recorder: could not write a %s message", item[0])
                self.writer_cpu_s += time.thread_time() - start
                if self.dropped > last_warned:
                    logger.warning(
                        "recorder: %d messages dropped so far (queue full: the writer is behind)",
                        self.dropped,
                    )
                    last_warned = self.dropped * 2  # warn again when the count doubles
            finally:
                self._queue.task_done()

    def _channel(self, name: str, factory: Callable[[], Any]) -> Any:
        channel = self._channels.get(name)
        if channel is None:
            channel = self._channels[name] = factory()
        return channel

    def _json_channel(self, name: str, cls: type[msgspec.Struct] | None = None) -> Any:
        title = "interbot" + "".join(part.title() for part in re.split(r"[/_]", name))
        schema: dict[str, Any] = {"type": "object", "title": title}
        if cls is not None:  # msgspec's JSON Schema of a declared message, for Foxglove's plots
            schema = msgspec.json.schema(cls)["$defs"][cls.__name__]
        return self._channel(
            name, lambda: foxglove.Channel(name, schema=schema, context=self._context)
        )

    def _log(
        self, name: str, kind: Any, message: Any, now: float, latch: bool = False, **extra: Any
    ) -> None:
        """Log ``message`` on channel ``name`` of Foxglove channel class ``kind`` (made on first
        use, with ``extra`` such as metadata); a ``latch`` message is repeated in a new file."""
        channel = self._channel(name, lambda: kind(name, context=self._context, **extra))
        channel.log(message, log_time=ns(self.epoch_offset + now))
        if latch:
            self._latched[name] = (now, message)

    def _log_json(
        self, name: str, data: dict[str, Any], now: float, cls: type[msgspec.Struct] | None = None
    ) -> None:
        self._json_channel(name, cls).log(data, log_time=ns(self.epoch_offset + now))

    def _write(self, item: tuple[Any, ...]) -> None:
        kind, now = item[0], float(item[1])
        self._maybe_rotate(now)
        t = self.epoch_offset + now
        if kind == "state":
            self._write_state(item[2], item[3], now, t)
        elif kind == "command":
            topic, message, source = item[2], item[3], item[4]
            body = message_dict(message) if is_message(message) else message
            self._log_json(
                COMMANDS, {"topic": topic, "source": source, "stamp": now, "message": body}, now
            )
            if isinstance(message, RouteMsg):
                self._log(
                    ROUTE,
                    PosesInFrameChannel,
                    fc.path_message(t, message.waypoints),
                    now,
                    latch=True,
                )
        elif kind == "json":
            data = item[3]
            if is_message(data):
                data = message_dict(data)
            self._log_json(item[2], jsonable(dict(data)), now)
        else:
            raise ValueError(f"unknown recorder item {kind!r}")

    def _write_state(self, topic: Topic, message: Any, now: float, t: float) -> None:
        if topic is Topic.SCAN and isinstance(message, LaserScan):
            meta = {"range_min": repr(message.range_min), "range_max": repr(message.range_max)}
            scan = fc.scan_message(self.epoch_offset + message.stamp, message)  # sensor time
            self._log(SCAN, LaserScanChannel, scan, now, metadata=meta)
            if "/tf_static" not in self._latched:
                mount = fc.laser_mount_transform(self.epoch_offset + now, self._laser_mount)
                self._log("/tf_static", FrameTransformsChannel, mount, now, latch=True)
        elif topic is Topic.MAP and isinstance(message, OccupancyGrid):
            self._log(MAP, GridChannel, fc.grid_message(t, message), now, latch=True)
        elif topic is Topic.IMAGE and isinstance(message, ImageMsg | bytes):
            jpeg = message.jpeg if isinstance(message, ImageMsg) else message
            self._log(CAMERA_JPEG, CompressedImageChannel, fc.jpeg_message(t, jpeg), now)
        elif topic in JSON_STATE_TOPICS and isinstance(message, JsonMessage):
            self._log_json(JSON_STATE_TOPICS[topic], message_dict(message), now, type(message))
            if isinstance(message, PoseMsg):
                self._pose = (
                    Pose2D(message.x, message.y, message.yaw) if message.state != "unset" else None
                )
                if not self._odom_seen:
                    self._log_tf(fc.robot_transforms(t, self._pose, None), now)
            elif isinstance(message, PlanMsg):  # the path the station draws, for Foxglove too
                points = fc.path_with_headings(message.points)
                self._log(
                    PLANNED_PATH, PosesInFrameChannel, fc.path_message(t, points), now, latch=True
                )
            elif isinstance(message, Odom):
                self._odom_seen = True
                odom = Pose2D(message.x, message.y, message.yaw)
                self._log_tf(fc.robot_transforms(t, self._pose, odom), now)
        else:
            raise ValueError(f"cannot record {type(message).__name__} on {topic}")

    def _log_tf(self, transforms: Any, now: float) -> None:
        self._log(TF, FrameTransformsChannel, transforms, now)

    # ------------------------------------------------------------------ files

    def _open(self, path: Path) -> None:
        try:
            self._writer = foxglove.open_mcap(
                path,
                allow_overwrite=True,
                context=self._context,
                writer_options=MCAPWriteOptions(
                    compression=MCAPCompression.Zstd,
                    chunk_size=self._chunk_bytes,
                    compression_threads=0,
                ),
            )
        except Exception as exc:
            raise RecorderError(f"cannot open {path} for recording: {exc}") from None
        self._writer.write_metadata(
            "interbot", {"robot_id": self.robot_id, "epoch_offset": repr(self.epoch_offset)}
        )
        self.files.append(path)
        self._file_start = None
        self._since_size_check = 0
        logger.info("recording to %s", path)

    def _open_first_file(self) -> None:
        if self._single_file is not None:
            self._single_file.parent.mkdir(parents=True, exist_ok=True)
            self._open(self._single_file)
        elif self._rotation is not None:
            self._rotation.prune()
            self._open(self._rotation.next_path())

    def _maybe_rotate(self, now: float) -> None:
        rotation = self._rotation
        if rotation is None or self._writer is None:
            return
        if self._file_start is None:
            self._file_start = now
        too_old = now - self._file_start >= rotation.config.max_file_seconds
        self._since_size_check += 1
        too_big = False
        if self._since_size_check >= SIZE_CHECK_PERIOD:
            self._since_size_check = 0
            too_big = (
                _size(self.files[-1]) >= rotation.config.max_file_bytes - 2 * self._chunk_bytes
            )
        if not (too_old or too_big):
            return
        self._writer.close()
        rotation.prune()
        self._open(rotation.next_path())
        self._file_start = now
        for name, (_, message) in list(self._latched.items()):  # every file stands alone
            self._channels[name].log(message, log_time=ns(self.epoch_offset + now))
