"""The collision monitor in the running stack: the Base Station's keyboard teleoperation (assist
off, its default) driven at a wall of the simulated ISR floor stops before contact; the daemon
switches assistance on the ``teleop_assist`` command and reports the monitor on ``safety``."""

from __future__ import annotations

import math

import pytest

from base_station_app.teleop import Direction, TeleopInput
from interbot_core.geometry import Pose2D
from interbot_core.topics import AssistMsg, SafetyMsg, Topic
from interbot_link import Command
from robot_daemon.config import DaemonConfig, SimSettings
from robot_daemon.daemon import Daemon, DaemonOptions, safety_message
from robot_daemon.scenarios.runner import ScenarioOptions, SimulatedSystem
from robot_daemon.stack import StackError

WALL_X = -33.8  # [m] west wall of the Main Entrance hall on ISR floor 0


def test_station_keyboard_teleop_at_a_wall_stops_before_contact() -> None:
    system = SimulatedSystem(
        ScenarioOptions(people=0), start_pose=Pose2D(-32.0, 3.7, math.pi), autonomy=False
    )
    system.localise()
    stack = system.stack
    assert not stack.guard.assisted("station_vel")  # the station's default: monitor only
    keys = TeleopInput(linear_max=0.6, angular_max=0.8)
    keys.press(Direction.FORWARD)  # the operator holds the up arrow
    clearance = math.inf
    for k in range(200):  # up to 10 s at the daemon's loop rate; the station repeats at 10 Hz
        if k % 2 == 0:
            stack.on_twist("station_vel", *keys.command(), system.now)
        system.step()
        clearance = min(clearance, system.sim.min_clearance())
        if k > 40 and system.sim.true_velocity() == (0.0, 0.0):
            break
    truth = system.sim.true_pose()
    assert system.sim.collisions == 0
    assert clearance > 0.01
    assert truth.x - 0.3 - WALL_X < 0.35  # it did drive up to the wall (1.5 m)
    assert system.sim.true_velocity()[0] == pytest.approx(0.0, abs=1e-3)
    assert stack.last_output.linear == 0.0 and "collision monitor" in stack.last_output.reason
    report = stack.guard.report()
    assert report.zone in ("stop", "approach") and report.distance < 0.2
    # Backing away is allowed at once.
    stack.on_twist("station_vel", -0.3, 0.0, system.now)
    system.step()
    system.step()
    assert stack.last_output.linear < 0.0
    with pytest.raises(StackError, match="station_vel or tablet_vel"):
        stack.set_teleop_assist("planner_vel", True, system.now)


def test_daemon_switches_assistance_and_reports_the_monitor() -> None:
    daemon = Daemon(DaemonConfig(sim=SimSettings(people=0)), DaemonOptions(auto_localise=True))
    stack = daemon.stack
    assert stack.guard.assisted("tablet_vel") and not stack.guard.assisted("station_vel")
    daemon.handle(Command(Topic.TELEOP_ASSIST, AssistMsg("station_vel", True)))
    assert stack.guard.assisted("station_vel")
    assert any("assisted teleoperation on" in e.text for e in stack.drain_events())
    msg = safety_message(stack, 0.0)
    assert isinstance(msg, SafetyMsg)
    assert msg.zone == "no_data"  # no scan yet: the monitor says it cannot see
    assert set(msg.assisted) == {"station_vel", "tablet_vel"}
    daemon.now = 0.2
    daemon.backend.advance(0.2)  # type: ignore[attr-defined]
    stack.step(0.2)
    msg = safety_message(stack, 0.2)
    assert msg.zone != "no_data" and 0.0 <= msg.distance <= 1000.0


def test_daemon_refuses_a_bad_safety_file(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from robot_daemon.config import ConfigError, parse_config

    bad = tmp_path / "monitor.yaml"
    bad.write_text(
        "collision_monitor:\n  polygons: [Stop]\n  Stop: {points: [[0.4, 0.3], [-0.4, 0.3],"
        " [-0.4, -0.3]], action_type: stop, slowdown_ratio: 3}\n"
    )
    config = parse_config({"safety": "monitor.yaml"}, "robot.yaml", tmp_path)
    assert config.safety_yaml == bad
    with pytest.raises(ConfigError, match=r"monitor\.yaml.*slowdown_ratio"):
        Daemon(config)
