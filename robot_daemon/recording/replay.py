"""``interbot replay FILE.mcap``: a recording played back as a robot the station can watch.

`RecordingSource` reads an MCAP file written by the `Recorder` (indexed) and turns its channels
back into the link's messages: the JSON state channels decode with the link's own validating
codecs, the map, scans and camera frames with the protobuf classes of the schemas stored in the
file (`foxglove_convert`), and the station's recorded commands become status lines
("replay: station sent stop …"), so the station's log shows who commanded what.

`ReplayPlayer` publishes every message whose recording time the `ReplayClock` has passed; a seek
restarts the reading there and first republishes the newest map (and pose) before that point.
`serve_replay` runs it on zenoh as robot ``<robot_id>``: the usual ``interbot/<id>/…`` topics and
liveliness token through a `RobotLink`, and replay control on ``interbot-replay/<id>/…``.
Commands a station sends to a replayed robot are answered with one warning and otherwise ignored.
"""

from __future__ import annotations

import json
import logging
import re
import struct
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace
from pathlib import Path
from typing import IO, Any

from google.protobuf.message import DecodeError, Message
from mcap.exceptions import McapError
from mcap.reader import SeekingReader, make_reader

from interbot_core.replay_control import ReplayClock, ReplayCommand
from interbot_core.topics import ImageMsg, RangeEncoding, Status, Topic, TopicError, decode
from interbot_link import RobotLink, open_session
from interbot_link.replay import ReplayControlServer
from robot_daemon.daemon import _jpeg_size
from robot_daemon.recording import foxglove_convert as fc
from robot_daemon.recording.recorder import (
    CAMERA_JPEG,
    COMMANDS,
    JSON_STATE_TOPICS,
    MAP,
    SCAN,
)

logger = logging.getLogger(__name__)

JSON_TOPICS = {name: topic for topic, name in JSON_STATE_TOPICS.items()}
REPLAYED = [*JSON_TOPICS, SCAN, MAP, CAMERA_JPEG, COMMANDS]
STATE_PERIOD = 0.2  # [s] wall time between two replay-state messages
LOOP_PERIOD = 0.01  # [s]
STALE_S = 1.0  # [s] of recording time: older scans and frames are skipped when behind


class ReplayFileError(ValueError):
    """The file cannot be replayed (not MCAP, not finished, not from this recorder)."""


@dataclass(frozen=True)
class ReplayItem:
    t: float  # [s] recording time from the start
    topic: Topic
    message: object


class RecordingSource:
    """One finished MCAP recording, opened for random access."""

    def __init__(self, path: Path) -> None:
        self.path = path
        try:
            self._file: IO[bytes] = path.open("rb")
        except OSError as exc:
            raise ReplayFileError(f"cannot open {path}: {exc.strerror}") from None
        try:
            reader = make_reader(self._file)
            summary = reader.get_summary() if isinstance(reader, SeekingReader) else None
        except (McapError, ValueError, EOFError, struct.error) as exc:
            self._file.close()
            raise ReplayFileError(f"{path} is not an MCAP file ({exc})") from None
        if summary is None or summary.statistics is None or not summary.statistics.message_count:
            self._file.close()
            raise ReplayFileError(
                f"{path} has no summary or no messages: was the recording cut short? "
                "(`mcap recover` can rebuild an unfinished file)"
            )
        assert isinstance(reader, SeekingReader)
        self._reader = reader
        self.start_ns = summary.statistics.message_start_time
        self.end_ns = summary.statistics.message_end_time
        self.duration = (self.end_ns - self.start_ns) / 1e9
        self._scan_range = (0.0, 30.0)
        self._classes: dict[str, type[Message]] = {}  # channel -> its protobuf message class
        for channel in summary.channels.values():
            schema = summary.schemas.get(channel.schema_id)
            if (
                schema is not None
                and schema.encoding == "protobuf"
                and channel.topic in (SCAN, MAP, CAMERA_JPEG)
            ):
                try:
                    self._classes[channel.topic] = fc.message_class(schema.name, schema.data)
                except (DecodeError, TypeError, KeyError) as exc:
                    self._file.close()
                    raise ReplayFileError(f"{path}: schema {schema.name}: {exc}") from None
            if channel.topic == SCAN and "range_max" in channel.metadata:
                meta = channel.metadata
                self._scan_range = (float(meta["range_min"]), float(meta["range_max"]))
        meta = next(
            (dict(m.metadata) for m in self._reader.iter_metadata() if m.name == "interbot"), {}
        )
        m = re.match(r"^([A-Za-z0-9_-]{1,32})_\d{8}-\d{6}_\d+$", path.stem)
        self.robot_id = meta.get("robot_id") or (m.group(1) if m else "replay")
        try:
            # Log and sensor times are wall-clock; the messages' stamps are the robot's time.
            self.epoch_offset = float(meta.get("epoch_offset", "0"))
        except ValueError:
            self.epoch_offset = 0.0
        self.decode_errors = 0

    def close(self) -> None:
        self._file.close()

    def items(self, start: float = 0.0) -> Iterator[ReplayItem]:
        """Every replayed message from ``start`` [s] on, in log-time order."""
        start_ns = self.start_ns + round(start * 1e9)
        for _, channel, message in self._reader.iter_messages(REPLAYED, starting_at=start_ns):
            item = self._decode(channel.topic, message.log_time, message.data)
            if item is not None:
                yield item

    def latest(self, topic: str, before: float) -> ReplayItem | None:
        """The newest message on ``topic`` at or before ``before`` [s]."""
        end_ns = self.start_ns + round(before * 1e9)
        for _, channel, message in self._reader.iter_messages(
            [topic], ending_at=end_ns, reverse=True
        ):
            return self._decode(channel.topic, message.log_time, message.data)
        return None

    def _decode(self, name: str, log_time: int, data: bytes) -> ReplayItem | None:
        t = (log_time - self.start_ns) / 1e9
        robot_time = log_time / 1e9 - self.epoch_offset  # what the daemon stamped it with
        try:
            if name in JSON_TOPICS:
                return ReplayItem(t, JSON_TOPICS[name], decode(JSON_TOPICS[name], data))
            if name == SCAN:
                scan = fc.scan_from(self._protobuf(name, data), *self._scan_range)
                stamped = replace(scan, stamp=scan.stamp - self.epoch_offset)  # sensor time
                return ReplayItem(t, Topic.SCAN, stamped)
            if name == MAP:
                return ReplayItem(t, Topic.MAP, fc.grid_from(self._protobuf(name, data)))
            if name == CAMERA_JPEG:
                image: Any = self._protobuf(name, data)
                if image.format != "jpeg":
                    raise ValueError(f"camera format {image.format!r}, not jpeg")
                jpeg = image.data
                return ReplayItem(t, Topic.IMAGE, ImageMsg(robot_time, *_jpeg_size(jpeg), jpeg))
            if name == COMMANDS:
                return ReplayItem(
                    t,
                    Topic.STATUS,
                    Status("info", command_line(json.loads(data)), stamp=robot_time),
                )
        except (TopicError, DecodeError, ValueError) as exc:
            self.decode_errors += 1
            if self.decode_errors <= 5:
                logger.warning("replay: skipped a %s message at %.2f s: %s", name, t, exc)
        return None

    def _protobuf(self, name: str, data: bytes) -> Message:
        if name not in self._classes:
            raise ValueError(f"{name} has no protobuf schema in the file")
        return self._classes[name].FromString(data)


def command_line(command: dict[str, Any]) -> str:
    """A recorded command as one line of the station's log."""
    message = command.get("message")
    detail = json.dumps(message, separators=(",", ":"))[:160] if message is not None else ""
    return (
        f"replay: {command.get('source', '?')} sent {command.get('topic', '?')} {detail}".rstrip()
    )


class ReplayPlayer:
    """Publishes a `RecordingSource` along a `ReplayClock` (wall time ``now`` passed in)."""

    def __init__(
        self,
        source: RecordingSource,
        publish: Callable[[ReplayItem], None],
        now: float,
        *,
        speed: float = 1.0,
        playing: bool = True,
    ) -> None:
        self.source = source
        self.clock = ReplayClock(source.duration, now, speed=speed, playing=playing)
        self._publish = publish
        self.skipped = 0
        self._restart(0.0)

    def _restart(self, position: float) -> None:
        emitted = set()
        for topic in (MAP, "/pose"):  # what the station needs to draw anything at all
            item = self.source.latest(topic, position)
            if item is not None:
                self._publish(item)
                emitted.add((item.topic, item.t))
        self._items = (i for i in self.source.items(position) if (i.topic, i.t) not in emitted)
        self._next = next(self._items, None)

    def command(self, command: ReplayCommand, now: float) -> None:
        was_finished = self.clock.position(now) >= self.clock.duration
        self.clock.apply(command, now)
        if command.action == "seek" or (command.action == "play" and was_finished):
            self._restart(self.clock.position(now))

    def step(self, now: float) -> int:
        """Publish what is due by ``now``; the number of messages published.

        When the player is behind (a slow machine, a long pause of its loop), scans and camera
        frames more than `STALE_S` of recording time old are skipped (counted in ``skipped``):
        the station shows only the newest of those anyway. Everything else, the map first, is
        always published.
        """
        position = self.clock.position(now)
        count = 0
        while self._next is not None and self._next.t <= position + 1e-9:
            item = self._next
            if item.topic in (Topic.SCAN, Topic.IMAGE) and item.t < position - STALE_S:
                self.skipped += 1
            else:
                self._publish(item)
                count += 1
            self._next = next(self._items, None)
        return count


def link_publisher(link: RobotLink) -> Callable[[ReplayItem], None]:
    def publish(item: ReplayItem) -> None:
        if item.topic is Topic.SCAN:
            link.publish_scan(item.message, RangeEncoding.UINT16_MM)  # type: ignore[arg-type]
        else:
            link.publish(item.topic, item.message)

    return publish


def serve_replay(
    path: Path,
    listen: list[str],
    connect: list[str],
    stop: threading.Event,
    *,
    robot_id: str | None = None,
    speed: float = 1.0,
    paused: bool = False,
    clock: Callable[[], float] = time.monotonic,
    ready: Callable[[str], None] | None = None,
) -> None:
    """Play ``path`` on zenoh until ``stop`` is set (a finished replay waits at its end)."""
    source = RecordingSource(path)
    robot = robot_id or source.robot_id
    try:
        with open_session(listen, connect) as session:
            link = RobotLink(session, robot)
            control = ReplayControlServer(session, robot)
            try:
                player = ReplayPlayer(
                    source, link_publisher(link), clock(), speed=speed, playing=not paused
                )
                logger.info("replaying %s (%.1f s) as robot %r", path.name, source.duration, robot)
                if ready is not None:
                    ready(robot)
                _run(player, link, control, stop, clock, path.name)
            finally:
                control.close()
                link.close()
    finally:
        source.close()


def _run(
    player: ReplayPlayer,
    link: RobotLink,
    control: ReplayControlServer,
    stop: threading.Event,
    clock: Callable[[], float],
    name: str,
) -> None:
    next_state = 0.0
    warned = False
    while not stop.is_set():
        now = clock()
        commands = control.poll_commands()
        for command in commands:
            player.command(command, now)
        if link.poll_commands() and not warned:
            warned = True
            text = "this robot is a replay of a recording: its commands are ignored"
            link.publish(Topic.STATUS, Status("warning", text, stamp=player.clock.position(now)))
        player.step(now)
        if commands or now >= next_state:
            control.publish_state(player.clock.state(now, name))
            next_state = now + STATE_PERIOD
        stop.wait(LOOP_PERIOD)
