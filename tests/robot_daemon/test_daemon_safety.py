"""Issue 11 in the daemon: the start latch, the loop that survives a component's error and
leaves the motors at zero on every way out."""

from __future__ import annotations

import threading
import time
from pathlib import Path
from unittest import mock

import pytest

from interbot_core.topics import Lock, Status, StopRelease, Topic, Twist
from interbot_link import Command
from interbot_link.robot import MOTION_TOPICS, PRIORITY_TOPICS
from robot_daemon.config import ConfigError, DaemonConfig, SimSettings, parse_config
from robot_daemon.daemon import SLOW_PASS, Daemon, DaemonOptions
from robot_daemon.systemd_notify import SystemdNotifier


class RecordingLink:
    """Enough of `RobotLink` for the loop: commands in, everything published recorded."""

    def __init__(self, commands: list[Command] | None = None) -> None:
        self.commands = list(commands or [])
        self.statuses: list[Status] = []

    def poll_commands(self, motion: bool | None = None) -> list[Command]:
        """The lanes as `RobotLink` splits them: motion (with stop) or the rest, or all."""
        fast = {Topic(t) for t in MOTION_TOPICS | PRIORITY_TOPICS}
        out = [c for c in self.commands if motion is None or (c.topic in fast) == motion]
        self.commands = [c for c in self.commands if c not in out]
        return out

    def wait_commands(self, timeout: float, motion: bool | None = None) -> bool:
        return False

    def subscribed(self, topic: Topic) -> bool:
        return False

    def publish(self, topic: Topic, message: object) -> None:
        if isinstance(message, Status):
            self.statuses.append(message)

    def __getattr__(self, name: str) -> object:
        if name.startswith("publish"):
            return lambda *args, **kwargs: None
        raise AttributeError(name)


@pytest.fixture(scope="module")
def shared() -> Daemon:
    """One daemon for the tests that do not care about its stop latch (building one is slow)."""
    return Daemon(DaemonConfig(sim=SimSettings(people=0)), DaemonOptions(auto_localise=True))


@pytest.fixture
def daemon() -> Daemon:
    return Daemon(DaemonConfig(sim=SimSettings(people=0)), DaemonOptions(auto_localise=True))


def test_start_latched_is_the_default_and_validated(tmp_path: Path) -> None:
    assert DaemonConfig().start_latched is True
    assert parse_config({"start_latched": False}, "r.yaml", tmp_path).start_latched is False
    with pytest.raises(ConfigError, match="'start_latched' must be true or false"):
        parse_config({"start_latched": "yes"}, "r.yaml", tmp_path)


def test_a_started_daemon_does_not_move_until_released(daemon: Daemon) -> None:
    # Motion commands are applied by the command thread (`apply_motion`), the loop's passes
    # keep the output; both go through the stop latch.
    link = RecordingLink([Command(Topic.STATION_VEL, Twist(0.3, 0.0))])
    daemon.apply_motion(link, link.poll_commands(motion=True))  # type: ignore[arg-type]
    daemon._pass(link, SystemdNotifier({}), 0.0)  # type: ignore[arg-type]
    out = daemon.stack.last_output
    assert (out.linear, out.angular) == (0.0, 0.0) and "Emergency Stop" in out.active_locks
    link.commands = [
        Command(Topic.STOP_RELEASE, StopRelease("station")),
        Command(Topic.STATION_VEL, Twist(0.3, 0.0, stamp=1.0)),
    ]
    daemon.apply_motion(link, link.poll_commands(motion=True))  # type: ignore[arg-type]
    assert daemon.stack.last_output.linear == pytest.approx(0.3)
    daemon._pass(link, SystemdNotifier({}), 0.0)  # type: ignore[arg-type]
    assert daemon.stack.last_output.linear == pytest.approx(0.3)


def test_a_component_error_is_reported_and_stops_the_robot(shared: Daemon) -> None:
    daemon = shared
    link = RecordingLink()
    commands: list[tuple[float, float]] = []
    real = daemon.backend.set_cmd_vel
    daemon.backend.set_cmd_vel = lambda v, w, now: (commands.append((v, w)), real(v, w, now))  # type: ignore[method-assign]
    with mock.patch.object(daemon.stack, "step", side_effect=RuntimeError("scan matcher exploded")):
        next_tick = daemon._pass(link, SystemdNotifier({}), 0.0)  # type: ignore[arg-type]
    assert next_tick > 0.0  # the loop carries on
    assert daemon.component_errors == 1
    assert commands[-1] == (0.0, 0.0)
    assert link.statuses and "scan matcher exploded" in link.statuses[-1].text
    assert link.statuses[-1].level == "error"


def test_every_exit_sets_the_motors_to_zero(shared: Daemon) -> None:
    daemon = shared
    commands: list[tuple[float, float]] = []
    daemon.backend.set_cmd_vel = lambda v, w, now: commands.append((v, w))  # type: ignore[method-assign]
    link = RecordingLink()
    with (
        mock.patch.object(daemon, "_pass", side_effect=KeyboardInterrupt),
        pytest.raises(KeyboardInterrupt),
    ):
        daemon.run(link, threading.Event(), SystemdNotifier({}))  # type: ignore[arg-type]
    assert commands == [(0.0, 0.0)]


def test_a_slow_loop_pass_is_counted_and_logged(
    daemon: Daemon, caplog: pytest.LogCaptureFixture
) -> None:
    """A pass that held commands back longer than SLOW_PASS is said in the log, not hidden."""
    before = daemon.slow_passes
    real_step = daemon.stack.step

    def slow_step(now: float) -> object:
        out = real_step(now)
        time.sleep(SLOW_PASS + 0.02)
        return out

    with mock.patch.object(daemon.stack, "step", side_effect=slow_step):
        link = RecordingLink()
        daemon._pass(link, SystemdNotifier({}), 0.0)  # type: ignore[arg-type]
    assert daemon.slow_passes == before + 1, link.statuses
    assert any("slow control loop pass" in r.getMessage() for r in caplog.records)
    daemon._pass(RecordingLink(), SystemdNotifier({}), 0.0)  # type: ignore[arg-type]
    assert daemon.slow_passes == before + 1  # a normal pass is not counted


class LaneLink(RecordingLink):
    """`RecordingLink` whose lanes can be waited on from two threads, like `RobotLink`'s."""

    def __init__(self) -> None:
        super().__init__()
        self.cond = threading.Condition()
        self.muxes: list[object] = []

    def push(self, *commands: Command) -> None:
        with self.cond:
            self.commands.extend(commands)
            self.cond.notify_all()

    def poll_commands(self, motion: bool | None = None) -> list[Command]:
        with self.cond:
            return super().poll_commands(motion)

    def wait_commands(self, timeout: float, motion: bool | None = None) -> bool:
        fast = {Topic(t) for t in MOTION_TOPICS | PRIORITY_TOPICS}

        def pending() -> bool:
            return any(motion is None or (c.topic in fast) == motion for c in self.commands)

        with self.cond:
            return self.cond.wait_for(pending, timeout)

    def publish(self, topic: Topic, message: object) -> None:
        super().publish(topic, message)
        if topic is Topic.MUX:
            self.muxes.append(message)


def test_motion_commands_reach_the_motors_while_the_localiser_runs_and_the_stop_wins() -> None:
    """Issue 14: the command thread applies teleoperation and the stop at once, while the loop
    thread is inside a long localiser pass; every output goes through the collision monitor."""
    daemon = Daemon(DaemonConfig(sim=SimSettings(people=0)), DaemonOptions(auto_localise=True))
    motors: list[tuple[float, float]] = []
    real_set = daemon.backend.set_cmd_vel
    daemon.backend.set_cmd_vel = lambda v, w, now: (motors.append((v, w)), real_set(v, w, now))  # type: ignore[method-assign]
    limited = [0]
    real_limit = daemon.stack.guard.limit

    def limit(output: object, now: float) -> object:
        limited[0] += 1
        return real_limit(output, now)  # type: ignore[arg-type]

    daemon.stack.guard.limit = limit  # type: ignore[method-assign]
    in_localiser, finish = threading.Event(), threading.Event()
    real_on_scan = daemon.stack.localiser.on_scan

    def slow_on_scan(scan: object, now: float) -> object:
        in_localiser.set()
        assert finish.wait(10.0), "the test never let the localiser finish"
        return real_on_scan(scan, now)  # type: ignore[arg-type]

    daemon.stack.localiser.on_scan = slow_on_scan  # type: ignore[method-assign]
    link, stop = LaneLink(), threading.Event()
    loop = threading.Thread(target=daemon.run, args=(link, stop, SystemdNotifier({})), daemon=True)
    loop.start()
    try:
        assert in_localiser.wait(10.0)
        link.push(
            Command(Topic.STOP_RELEASE, StopRelease("station")),
            Command(Topic.TABLET_VEL, Twist(0.0, 0.3)),
        )
        deadline = time.monotonic() + 5.0
        while (0.0, 0.3) not in motors and time.monotonic() < deadline:
            time.sleep(0.005)
        assert (0.0, 0.3) in motors and not finish.is_set()  # applied during the pass
        assert link.muxes and link.muxes[-1].angular == pytest.approx(0.3)  # type: ignore[attr-defined]
        checked = limited[0]
        assert checked >= 1
        # The stop, then more driving, still inside the same pass: zero, and zero stays.
        link.push(Command(Topic.STOP, Lock(True)), Command(Topic.TABLET_VEL, Twist(0.0, 0.5)))
        deadline = time.monotonic() + 5.0
        while motors[-1] != (0.0, 0.0) and time.monotonic() < deadline:
            time.sleep(0.005)
        assert motors[-1] == (0.0, 0.0) and (0.0, 0.5) not in motors
        assert "Emergency Stop" in daemon.stack.last_output.active_locks
        assert limited[0] > checked and not finish.is_set()
    finally:
        finish.set()
        stop.set()
        loop.join(10.0)
    assert not loop.is_alive()
    assert motors[-1] == (0.0, 0.0) and (0.0, 0.5) not in motors
