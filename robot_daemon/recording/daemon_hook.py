"""How the daemon records: a `RobotLink` that also hands what it publishes to a `Recorder`.

The daemon publishes everything the station sees through its link, and receives every command
through it, so recording at the link records exactly what the station saw and who commanded
what, at the daemon's own rates, without touching the control loop's code: ``serve()`` builds a
`RecordingLink` instead of a `RobotLink`. With each pose it also samples what only the robot
knows: the localiser's estimate (state, confidence, match score, and a covariance if the
localiser has one). The planner's path is the daemon's own ``plan`` topic (``/planned_path``).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import msgspec
import zenoh

from interbot_core.laser_scan import LaserScan
from interbot_core.topics import RangeEncoding, Status, Topic
from interbot_link import Command, RobotLink
from interbot_link.security import is_loopback_host
from robot_daemon.config import ConfigError, DaemonConfig, RecordingConfig
from robot_daemon.recording.recorder import LiveServer, McapRotation, Recorder, RecorderError
from robot_daemon.stack import RobotStack

if TYPE_CHECKING:
    from robot_daemon.daemon import Daemon, DaemonOptions


LOCALISATION = "/localisation"


class LiveAddressError(ValueError):
    """A ``--foxglove`` address that is malformed or not allowed (non-loopback without TLS)."""


def parse_live_address(text: str, *, tls: tuple[bytes, bytes] | None = None) -> LiveServer:
    """``[HOST:]PORT`` -> LiveServer; loopback only unless the server has TLS (``--security``).

    ``tls`` is (certificate PEM, PKCS#8 key PEM): the server then speaks wss:// only.

    >>> parse_live_address("8765")
    LiveServer(host='127.0.0.1', port=8765)
    """
    host, sep, port_text = text.rpartition(":")
    if not sep:
        host, port_text = "127.0.0.1", text
    host = host.strip("[]") or "127.0.0.1"
    if not port_text.isdigit() or not 0 <= int(port_text) <= 65535:
        raise LiveAddressError(f"--foxglove {text!r}: the port must be 0..65535 ([HOST:]PORT)")
    if not is_loopback_host(host) and tls is None:
        raise LiveAddressError(
            f"--foxglove {text!r}: refused to serve the robot's map, camera and pose on "
            f"{host}, which is not loopback: the Foxglove server has no authentication. "
            "Serve on 127.0.0.1 and reach it through an SSH tunnel, or give the daemon "
            "--security (TLS) when it has it."
        )
    return LiveServer(host, int(port_text), *(tls or ()))  # with TLS: wss:// only


class StackSampler:
    """What only the robot knows, sampled with each pose: the localiser's estimate."""

    def __init__(self, stack: RobotStack, recorder: Recorder) -> None:
        self._stack = stack
        self._recorder = recorder
        self._last_estimate: object = None

    def sample(self, now: float) -> None:
        stack, recorder = self._stack, self._recorder
        estimate = stack.last_estimate
        if estimate is not None and estimate is not self._last_estimate:
            self._last_estimate = estimate
            data: dict[str, Any] = {
                f.name: getattr(estimate, f.name)
                for f in dataclasses.fields(estimate)
                if f.name != "pose"
            }
            data["state"] = stack.localisation_state.value
            pose = estimate.pose
            if pose is not None:
                data.update(x=pose.x, y=pose.y, yaw=pose.yaw)
            covariance = getattr(estimate, "covariance", None)
            if covariance is not None:  # a localiser that estimates it
                data["covariance"] = [float(v) for v in getattr(covariance, "flat", covariance)]
            recorder.json(LOCALISATION, data, now)


class RecordingLink(RobotLink):
    """A `RobotLink` that offers every publication and every command to a `Recorder`."""

    def __init__(
        self,
        session: zenoh.Session,
        robot_id: str,
        recorder: Recorder,
        clock: Callable[[], float],
        sampler: StackSampler,
        **kwargs: Any,
    ) -> None:
        super().__init__(session, robot_id, **kwargs)
        self.recorder = recorder
        self._clock = clock
        self._sampler = sampler

    def publish(self, topic: Topic, message: object) -> None:
        super().publish(topic, message)
        now = self._clock()
        self.recorder.state(topic, message, now)
        if topic is Topic.POSE:
            self._sampler.sample(now)
            report = self.recorder.health_report()
            if report is not None:
                super().publish(Topic.STATUS, Status("warning", report, stamp=now))

    def publish_scan(
        self, scan: LaserScan, encoding: RangeEncoding = RangeEncoding.FLOAT32
    ) -> None:
        super().publish_scan(scan, encoding)
        self.recorder.state(Topic.SCAN, scan, self._clock())

    def subscribed(self, topic: Topic) -> bool:
        """The camera is encoded for the recording even when no station watches."""
        if topic is Topic.IMAGE and self.recorder.camera:
            return True
        return super().subscribed(topic)

    def poll_commands(self, motion: bool | None = None) -> list[Command]:
        commands = super().poll_commands(motion)
        now = self._clock()
        for command in commands:
            source = "tablet via station" if command.topic is Topic.TABLET_VEL else "station"
            self.recorder.command(command.topic, command.message, now, source)
        return commands


def build_recorder(
    robot_id: str,
    *,
    recording: RecordingConfig | None,
    record_dir: Path | None,
    live: LiveServer | None,
    now: float,
    wall_clock: Callable[[], float] = time.time,
) -> Recorder | None:
    """The daemon's recorder, or None when neither recording nor the live view is asked for.

    ``recording`` is robot.yaml's ``recording:`` section; ``record_dir`` (``--record DIR``) turns
    recording on with the section's other settings or the defaults. Raises RecorderError.
    """
    config = recording
    if record_dir is not None:
        config = msgspec.structs.replace(config or RecordingConfig(), directory=str(record_dir))
    if config is None and live is None:
        return None
    rotation = McapRotation(config, robot_id, wall_clock) if config is not None else None
    return Recorder(
        robot_id,
        rotation=rotation,
        live=live,
        epoch_offset=wall_clock() - now,
        queue_size=config.queue if config is not None else 2048,
        camera=config.camera if config is not None else True,
    )


def build_daemon_recorder(
    config: DaemonConfig,
    options: DaemonOptions,
    now: float,
    tls: tuple[bytes, bytes] | None = None,
) -> Recorder | None:
    """The recorder robot.yaml and the command line ask for; every refusal is a ConfigError.

    ``tls`` (the robot's certificate and key, with ``--security``) lets the live view listen
    beyond loopback, over wss:// only.
    """
    try:
        live = parse_live_address(options.foxglove, tls=tls) if options.foxglove else None
        return build_recorder(
            config.robot_id,
            recording=config.recording,
            record_dir=options.record_dir,
            live=live,
            now=now,
        )
    except (LiveAddressError, RecorderError) as exc:
        raise ConfigError(str(exc)) from None


def make_link(session: zenoh.Session, daemon: Daemon, recorder: Recorder | None) -> RobotLink:
    """The daemon's link: a plain `RobotLink`, or a `RecordingLink` when recording."""
    robot_id = daemon.config.robot_id
    if recorder is None:
        return RobotLink(session, robot_id)
    sampler = StackSampler(daemon.stack, recorder)
    return RecordingLink(session, robot_id, recorder, lambda: daemon.now, sampler)
