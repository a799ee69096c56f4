"""The tablet's session model without a screen: time is a number the test sets."""

from __future__ import annotations

from interbot_core.protocol import Cancel, GoalStatus, Localisation, Pose, StatusInfo
from tablet_app.tablet_session import CANCEL_GRACE_S, HELP_ANSWER_S, Help, TabletSession


def session() -> TabletSession:
    xy = {0: (0.0, 0.0), 4: (10.0, 0.0)}
    s = TabletSession(room_xy=xy.get, home_room=0)
    s.on_connected()
    return s


def test_progress_follows_the_pose() -> None:
    s = session()
    s.on_pose(Pose(0.0, 0.0, 0.0))
    s.goal_sent(4)
    s.on_pose(Pose(5.0, 0.0, 0.0))
    assert s.goal is not None and s.goal.progress == 50


def test_a_cancelled_goal_that_the_station_keeps_driving_is_shown_again() -> None:
    s = session()
    s.goal_sent(4)
    s.cancel_sent(now=10.0)
    s.on_goal_status(GoalStatus(4, False, False), now=10.5)  # in flight: ignored
    assert s.goal is None
    s.on_goal_status(GoalStatus(4, False, False), now=10.0 + CANCEL_GRACE_S + 0.1)
    assert s.goal is not None and s.goal.room == 4
    assert s.notice is not None and s.notice.key == "still_going" and s.notice.error


def test_idle_from_the_station_confirms_the_cancel() -> None:
    s = session()
    s.goal_sent(4)
    s.cancel_sent(now=0.0)
    s.on_status(StatusInfo("idle", "idle"))
    s.on_goal_status(GoalStatus(4, False, False), now=0.1)  # a new order for the same room
    assert s.goal is not None


def test_help_pose_unconfirmed_in_time_has_failed() -> None:
    s = session()
    s.on_localisation(Localisation("lost"))
    assert s.help is Help.OFFERED
    s.help_started()
    s.help_room_sent(4, now=0.0)
    assert s.help is Help.CHECKING and s.notice is not None and s.notice.key == "help_checking"
    s.tick(HELP_ANSWER_S - 0.1)
    assert s.help is Help.CHECKING
    s.tick(HELP_ANSWER_S + 0.1)
    assert s.help is Help.CHOOSING and s.notice is not None and s.notice.key == "help_failed"


def test_help_pose_confirmed_by_the_robot_says_thank_you() -> None:
    s = session()
    s.on_localisation(Localisation("unset"))
    s.help_started()
    s.help_room_sent(4, now=0.0)
    s.on_localisation(Localisation("ok"))
    assert s.help is Help.NONE
    assert s.notice is not None and (s.notice.key, s.notice.args) == ("help_thanks", (4,))


def test_reconnect_forgets_what_the_old_station_said() -> None:
    s = session()
    s.goal_sent(4)
    s.on_goal_status(GoalStatus(4, True, True), now=0.0)
    assert s.tour_stop == 4
    s.on_connected()
    assert s.goal is None and s.tour_stop is None and not s.tour.stops


def test_operator_cancel_is_said_and_clears_everything() -> None:
    s = session()
    s.goal_sent(4)
    s.on_cancel(Cancel("cancelled by the operator"))
    assert s.goal is None
    assert s.notice is not None and s.notice.key == "cancelled_by_operator"


def test_listeners_hear_every_change() -> None:
    s = session()
    heard: list[int] = []
    s.subscribe(lambda: heard.append(1))
    s.on_status(StatusInfo("idle", "navigating, 12.3 m to the next goal"))
    assert heard and s.activity == "navigating" and s.activity_distance == 12.3


def test_a_tour_stop_left_is_not_reopened_by_a_repeat() -> None:
    s = session()
    s.on_goal_status(GoalStatus(4, True, True), now=0.0)
    assert s.tour_stop == 4
    s.tour_control_sent("resume", now=1.0)
    s.on_goal_status(GoalStatus(4, True, True), now=1.1)  # sent before the station saw it
    assert s.tour_stop is None
    s.on_goal_status(GoalStatus(4, True, True), now=1.0 + CANCEL_GRACE_S + 0.1)
    assert s.tour_stop == 4  # the station really is still waiting there: ask again


def test_the_robot_name_changes_once_per_new_name() -> None:
    session = TabletSession()
    calls: list[str] = []
    session.subscribe(lambda: calls.append(session.robot))
    session.on_robot_name("bot1")
    session.on_robot_name("bot1")
    session.on_robot_name("bot4")
    assert calls == ["bot1", "bot4"] and session.robot == "bot4"
