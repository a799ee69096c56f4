"""Pure (Qt-free) parts of the Base Station: configuration, teleop merging, tablet policy,
room labels and the robot state model."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from base_station_app.map_labels import map_labels
from base_station_app.robot_state import RobotState
from base_station_app.station_config import RANGES, StationConfig, StationConfigError
from base_station_app.tablet_policy import TabletPolicy, allows, with_kind
from base_station_app.tablet_session import (
    ErrorBudget,
    describe_task,
    permission_for,
)
from base_station_app.teleop import Direction, TeleopInput
from interbot_core import protocol as p
from interbot_core.geometry import Pose2D
from interbot_core.supervisor import Delivery, GoHome, GoTo, GoToPose, GuidedTour
from interbot_core.topics import MuxMsg, PoseMsg, SafetyMsg, Topic


# ------------------------------------------------------------------ StationConfig
def test_config_defaults_are_valid_and_map_to_supervisor():
    c = StationConfig()
    s = c.supervisor_config()
    assert (s.approach_tolerance, s.goal_tolerance, s.yaw_tolerance) == (0.7, 0.25, 0.25)
    assert c.planner_params()["max_linear_speed"] == c.planner_linear_max


@pytest.mark.parametrize("name", sorted(RANGES))
def test_config_rejects_out_of_range_naming_field_and_range(name):
    _, hi, _ = RANGES[name]
    with pytest.raises(StationConfigError, match=rf"{name} = .* outside the allowed range"):
        StationConfig(**{name: hi * 2 + 1})
    with pytest.raises(StationConfigError, match=name):
        StationConfig(**{name: math.nan})
    with pytest.raises(StationConfigError, match="must be a number"):
        StationConfig(**{name: True})


# ------------------------------------------------------------------ TeleopInput
def test_teleop_keys_combine_and_release():
    t = TeleopInput(0.5, 1.0)
    assert not t.active and t.command() == (0.0, 0.0)
    t.press(Direction.FORWARD)
    t.press(Direction.RIGHT)
    assert t.command() == (0.5, -1.0)
    t.press(Direction.BACKWARD)  # opposite keys cancel
    assert t.command() == (0.0, -1.0)
    t.release_all()
    assert not t.active and t.command() == (0.0, 0.0)


def test_teleop_joystick_wins_and_is_clamped():
    t = TeleopInput(0.5, 1.0)
    t.press(Direction.FORWARD)
    t.set_joystick(-2.0, 0.3, pressed=True)
    assert t.command() == (-0.5, 0.3)
    t.set_joystick(0.0, 0.0, pressed=False)
    assert t.command() == (0.5, 0.0)
    with pytest.raises(ValueError, match="linear_max"):
        t.set_limits(0.0, 1.0)


@settings(max_examples=100)
@given(
    keys=st.sets(st.sampled_from(list(Direction))),
    lin=st.floats(0.01, 2.0),
    ang=st.floats(0.01, 3.0),
    joy=st.none() | st.tuples(st.floats(-10, 10), st.floats(-10, 10)),
)
def test_teleop_command_never_exceeds_limits(keys, lin, ang, joy):
    t = TeleopInput(lin, ang)
    for k in keys:
        t.press(k)
    if joy is not None:
        t.set_joystick(*joy, pressed=True)
    v, w = t.command()
    assert abs(v) <= lin and abs(w) <= ang
    assert t.active == bool(keys or joy is not None)


# ------------------------------------------------------------------ tablet policy
def test_permission_kinds_of_tablet_messages():
    assert permission_for(p.Speed(0.1, 0.0)) == "teleop"
    assert permission_for(p.Goal(3)) == "goals"
    assert permission_for(p.Home()) == "goals"
    assert permission_for(p.Tour(True)) == "tours"
    assert permission_for(p.TourControl("resume")) == "tours"
    assert permission_for(p.RequestFrom("x", 1, 2, True)) == "requests"
    for always in (p.Pause(True), p.Stop(True), p.InitialPoseRoom(2), p.Malfunction("other", "")):
        assert permission_for(always) is None
    perms = with_kind(TabletPolicy().permissions, "tours", False)
    assert not allows(perms, "tours") and allows(perms, "goals") and allows(perms, None)
    assert perms == p.Permissions(True, True, False, True)
    with pytest.raises(ValueError, match="unknown permission"):
        allows(perms, "flying")
    with pytest.raises(ValueError, match="unknown permission"):
        with_kind(perms, "flying", True)


def test_error_budget_closes_after_repeated_errors_in_window_or_fatal():
    b = ErrorBudget(max_errors=3, window_s=10.0)
    assert not any(b.record(t) for t in (0.0, 1.0, 2.0))
    assert b.record(3.0)  # the fourth within 10 s
    b.reset()
    assert not any(b.record(t) for t in (0.0, 20.0, 40.0, 60.0))  # spread out: fine
    assert b.record(61.0, fatal=True)


def test_describe_task_names_rooms():
    names = {3: "Restrooms", 7: "Lab"}
    assert describe_task(GoTo(3), names) == "go to Restrooms (3)"
    assert describe_task(GuidedTour()) == "guided tour"
    assert describe_task(GoHome()) == "go home"
    assert (
        describe_task(Delivery("pen", 7, 3), names) == "deliver 'pen' from Lab (7) to Restrooms (3)"
    )
    assert describe_task(GoToPose(Pose2D(1, 2, 0))).startswith("go to pose (1.00, 2.00")


# ------------------------------------------------------------------ room labels
def test_map_labels_one_per_room_name_and_number_wrapped(topo):
    """The rooms themselves are `interbot_core.rooms` (tests/interbot_core/test_rooms.py)."""
    from pathlib import Path

    from interbot_core.rooms import load_room_map

    rooms = load_room_map(Path(__file__).resolve().parents[2] / "maps" / "isr_floor0_topo.yaml")
    labels = map_labels(rooms, wrap=16)
    assert [lab.node_id for lab in labels] == [room.id for room in rooms.rooms]
    for label, room in zip(labels, rooms.rooms, strict=True):
        assert (label.x, label.y) == room.label and label.short == str(room.id)
        assert all(len(line) <= 16 for line in label.text.split("\n")), label.text
        assert f"({room.id})" in label.text and label.width == pytest.approx(room.width)


def test_map_labels_of_rooms_without_outlines_sit_at_their_nodes(topo):
    from interbot_core.rooms import room_map

    labels = map_labels(room_map(topo))
    assert len(labels) == len(topo)
    node = topo.nodes[0]
    first = next(lab for lab in labels if lab.node_id == node.id)
    assert (first.x, first.y) == pytest.approx((node.pose.x, node.pose.y))
    assert first.width == math.inf


# ------------------------------------------------------------------ RobotState
def test_robot_state_versions_and_derived_fields():
    s = RobotState(log_capacity=3)
    assert s.localisation == "unset" and s.localised_pose is None and s.estop_engaged is None
    s.apply(Topic.POSE, PoseMsg(1.0, 2.0, 0.5, state="lost"))
    assert s.version == 1 and s.localisation == "lost" and s.localised_pose is None
    s.apply(Topic.POSE, PoseMsg(1.0, 2.0, 0.5))
    assert s.localised_pose == Pose2D(1.0, 2.0, 0.5)
    s.apply(Topic.MUX, MuxMsg(None, "stop", ("stop",)))
    assert s.estop_engaged is True
    s.apply(Topic.SAFETY, SafetyMsg("approach", "FootprintApproach", 0.3, 0.8, 0.5))
    assert s.safety is not None and s.safety.zone == "approach"
    s.apply(Topic.POSE, "not a pose")  # ignored
    assert s.version == 4
    for i in range(5):
        s.add_log(float(i), "info", f"line {i}")
    assert [e.text for e in s.log] == ["line 2", "line 3", "line 4"]


def test_safety_text_for_the_person_driving():
    from interbot_core.safety_text import describe_safety

    stop = describe_safety("stop", 0.04, assisted=False)
    assert stop.text == "STOPPED: obstacle too close (4 cm); assisted driving off"
    assert stop.level == "error"
    assert describe_safety("none", 1000.0).text == "clear"
    assert describe_safety("slowdown", 0.3).level == "warning"
    assert describe_safety("no_data", 0.0).text == "STOPPED: no laser data"
