"""The tablet's one session model: what the robot is doing for this tablet, as the screens show it.

Qt-free, so the rules are tested without a screen. Every Base Station message and every user
action goes through a `TabletSession` method; screens only read it (``session.goal``,
``session.notice``, ...) when it tells its listeners that something changed. No screen keeps
its own copy, so nothing is left over after a cancel, the end of a tour or a station restart.

The rules that make the tablet honest:

* **The station owns the truth.** A (re)connection drops everything the old station said (goal,
  tour, the stop being shown, a request on screen); the new station re-sends its real state.
* **Sending is not succeeding.** "Help me!" puts the session in ``checking`` until the robot
  reports itself localised (then "Thank you!") or the station refuses or still reports it lost
  after `HELP_ANSWER_S` (then it says so and keeps asking for help).
* **A cancel is not undone by a message already in flight.** The station repeats the goal's
  status every ``clock()``; after the user cancels goal g, statuses of g are ignored for
  `CANCEL_GRACE_S` or until the station shows it is idle (and likewise "at tour stop" after
  Resume or End there). A station that keeps going to g
  after that is shown again, with a notice: never a bar that silently comes back, nor a robot
  that silently keeps driving.
* **An outcome stays on screen.** "Arrived at X", "Report sent" and refusals are the ``notice``,
  kept until the user's next action or the next outcome; the station's periodic status feeds
  the ``activity`` line, not the notice.

Strings are not made here: notices and activities are keys with arguments (rooms by id), and
the screens word them in the UI's language (English and Portuguese), at the time they show them.
"""

from __future__ import annotations

import enum
import itertools
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Final

from interbot_core.protocol import (
    Cancel,
    ErrorReport,
    GoalStatus,
    InitialPose,
    Localisation,
    Permissions,
    Pose,
    ShowRequest,
    StationMessage,
    StatusInfo,
    TourState,
)

logger = logging.getLogger(__name__)

CANCEL_GRACE_S = 2.0  # [s] goal statuses of a cancelled goal ignored this long
HELP_ANSWER_S = 6.0  # [s] a "Help me!" pose not confirmed by then has failed
LOST_STATES = frozenset({"unset", "lost"})


class Help(enum.StrEnum):
    """Where the "Help me!" conversation stands."""

    NONE = "none"  # localised: nothing to do
    OFFERED = "offered"  # lost: the button is shown
    CHOOSING = "choosing"  # the user pressed it: pick the room the robot is at
    CHECKING = "checking"  # a room was sent: waiting for the robot to confirm


@dataclass(frozen=True)
class Notice:
    """An outcome shown until the next action: ``key`` names the sentence, ``args`` fill it."""

    key: str
    args: tuple[str | int, ...] = ()  # an int is a room id, named in the UI's language
    error: bool = False


@dataclass
class GoalProgress:
    """The room the robot is taking the user to and how far along it is."""

    room: int
    start_distance: float | None = None  # [m] straight line at the start
    progress: int = 0  # [%]
    paused: bool = False


@dataclass
class TourProgress:
    stops: tuple[int, ...] = ()
    visited: frozenset[int] = frozenset()
    next: int | None = None


@dataclass
class TabletSession:
    """All the tablet shows about the robot, with ``now`` [s] from an injected clock."""

    room_xy: Callable[[int], tuple[float, float] | None] = lambda _room: None
    home_room: int | None = None
    connected: bool = False
    pose: tuple[float, float, float] | None = None
    localisation: str = "unknown"  # until the station says (unset, ok, lost, ...)
    help: Help = Help.NONE
    help_room: int | None = None
    goal: GoalProgress | None = None
    tour: TourProgress = field(default_factory=TourProgress)
    tour_stop: int | None = None  # the stop whose Resume/End dialog is open
    shown_request: ShowRequest | None = None
    permissions: Permissions = field(default_factory=lambda: Permissions(True, True, True, True))
    notice: Notice | None = None
    activity: str = "idle"  # the station's supervisor state, plain words chosen by the screen
    activity_distance: float | None = None  # [m] to the next goal, when the station says
    estop: bool = False
    robot: str = ""  # the robot this tablet drives, as the station names it ("" until told)
    _cancelled: tuple[int, float] | None = None  # (room, until) after the user's cancel
    _left_stop: tuple[int, float] | None = None  # (room, until) after Resume / End at a stop
    _help_deadline: float = math.inf
    _listeners: list[Callable[[], None]] = field(default_factory=list)

    # ------------------------------------------------------------------ observation
    def subscribe(self, listener: Callable[[], None]) -> None:
        self._listeners.append(listener)

    def _changed(self) -> None:
        for listener in list(self._listeners):
            listener()

    @property
    def lost(self) -> bool:
        return self.localisation in LOST_STATES

    def _say(self, key: str, *args: str | int, error: bool = False) -> None:
        self.notice = Notice(key, tuple(args), error)

    # ------------------------------------------------------------------ connection
    def on_connected(self) -> None:
        """A (new) station: forget what the old one said; it re-sends the real state."""
        self.connected = True
        self._forget_station_state()
        self._changed()

    def on_disconnected(self) -> None:
        self.connected = False
        self._changed()

    def _forget_station_state(self) -> None:
        self.goal = None
        self.tour = TourProgress()
        self.tour_stop = None
        self.shown_request = None
        self._cancelled = None
        self._left_stop = None
        self.estop = False
        self.activity, self.activity_distance = "idle", None
        if self.help is Help.CHECKING:
            self.help, self.help_room, self._help_deadline = Help.OFFERED, None, math.inf

    # ------------------------------------------------------------------ station messages
    def on_message(self, msg: StationMessage, now: float) -> None:
        """One validated message from the station, to the method for its type below."""
        if isinstance(msg, GoalStatus):
            self.on_goal_status(msg, now)
        elif (handler := _HANDLERS.get(type(msg))) is not None:
            handler(self, msg)

    def on_robot_name(self, name: str) -> None:
        """The station names the robot this tablet drives (at connect, and on a switch)."""
        if name != self.robot:
            self.robot = name
            self._changed()

    def on_pose(self, msg: Pose) -> None:
        """The station sends the pose only while the robot is localised (thesis §5.3.6)."""
        self.pose = (msg.x, msg.y, msg.angle)
        if self.localisation != "ok":
            self._set_localisation("ok")
        self._update_progress()
        self._changed()

    def on_initial_pose(self, msg: InitialPose) -> None:
        if not msg.is_set:
            self.pose = None
            self._set_localisation("unset")
        self._changed()

    def on_localisation(self, msg: Localisation) -> None:
        self._set_localisation(msg.state)
        self._changed()

    def _set_localisation(self, state: str) -> None:
        self.localisation = state
        if not self.lost:
            if self.help is Help.CHECKING and self.help_room is not None:
                self._say("help_thanks", self.help_room)
            self.help, self.help_room, self._help_deadline = Help.NONE, None, math.inf
        elif self.help is Help.NONE:
            self.help = Help.OFFERED

    def on_goal_status(self, msg: GoalStatus, now: float) -> None:
        if self._cancelled is not None:
            room, until = self._cancelled
            if msg.goal == room and not msg.reached and now < until:
                return  # a repeat sent before the station saw the cancel
            if msg.goal == room and not msg.reached:
                self._say("still_going", room, error=True)
            self._cancelled = None
        if msg.tour_reached:
            if self._left_stop is not None:
                room, until = self._left_stop
                if msg.goal == room and now < until:
                    return  # a repeat sent before the station saw Resume / End
                self._left_stop = None
            if self.tour_stop != msg.goal:
                self.tour_stop = msg.goal
                self.goal = None
            self._changed()
            return
        self.tour_stop = None
        if msg.reached:
            if self.goal is not None:
                self._say("arrived", msg.goal)
            self.goal = None
        elif self.goal is None or self.goal.room != msg.goal:
            self._start_goal(msg.goal)
        self._changed()

    def on_tour_state(self, msg: TourState) -> None:
        self.tour = TourProgress(msg.stops, frozenset(msg.visited), msg.next)
        if not msg.stops:
            self.tour_stop = None
        self._changed()

    def on_show_request(self, msg: ShowRequest) -> None:
        self.shown_request = msg
        self._changed()

    def on_cancel(self, msg: Cancel) -> None:
        self.goal = None
        self.tour_stop = None
        self.shown_request = None
        self._say("cancelled_by_operator", msg.reason)
        self._changed()

    def on_permissions(self, msg: Permissions) -> None:
        self.permissions = msg
        self._changed()

    def on_status(self, msg: StatusInfo) -> None:
        """The station's task and state: the activity line (never the notice)."""
        text = msg.message.strip()
        self.estop = text.startswith("emergency stop")
        state, _, rest = text.partition(",")
        self.activity = state.strip()
        self.activity_distance = _distance_in(rest)
        if msg.task == "idle" and self._cancelled is not None:
            self._cancelled = None  # the station has dropped the cancelled task
        if self.activity != "at tour stop":
            self._left_stop = None  # the station has left the stop
        if msg.task == "idle" and self.goal is not None and self.activity == "idle":
            self.goal = None  # the station has no task: no bar for a goal it forgot
        self._changed()

    def on_error(self, msg: ErrorReport) -> None:
        if self.help is Help.CHECKING:
            self._help_failed(msg.message)
        else:
            self._say("station_error", msg.message, error=True)
        self._changed()

    def on_refused(self, reason: str) -> None:
        self._say("refused", reason, error=True)
        self._changed()

    def tick(self, now: float) -> None:
        """Time passes: a "Help me!" pose the robot never confirmed has failed."""
        if self.help is Help.CHECKING and now >= self._help_deadline:
            self._help_failed("")
            self._changed()

    def _help_failed(self, reason: str) -> None:
        self._say(
            "help_failed", self.help_room if self.help_room is not None else "?", reason, error=True
        )
        self.help, self.help_room, self._help_deadline = Help.CHOOSING, None, math.inf

    # ------------------------------------------------------------------ user actions (sent)
    def goal_sent(self, room: int) -> None:
        self.notice = None
        self._cancelled = None
        self._start_goal(room)
        self._changed()

    def home_sent(self) -> None:
        self.notice = None
        if self.home_room is not None:
            self._start_goal(self.home_room)
        self._changed()

    def cancel_sent(self, now: float) -> None:
        if self.goal is not None:
            self._cancelled = (self.goal.room, now + CANCEL_GRACE_S)
        self.goal = None
        self._say("cancelled")
        self._changed()

    def pause_sent(self, paused: bool) -> None:
        if self.goal is not None:
            self.goal.paused = paused
        self._changed()

    def tour_sent(self) -> None:
        self._say("tour_requested")
        self._changed()

    def tour_control_sent(self, action: str, now: float) -> None:
        if self.tour_stop is not None:
            self._left_stop = (self.tour_stop, now + CANCEL_GRACE_S)
        self.tour_stop = None
        if action == "end":
            self.tour = TourProgress()
            self._say("tour_ended")
        else:
            self.notice = None
        self._changed()

    def help_started(self) -> None:
        if self.lost:
            self.help = Help.CHOOSING
            self.notice = None
            self._changed()

    def help_room_sent(self, room: int, now: float) -> None:
        self.help, self.help_room = Help.CHECKING, room
        self._help_deadline = now + HELP_ANSWER_S
        self._say("help_checking", room)
        self._changed()

    def report_sent(self, kind: str) -> None:
        self._say("report_sent", kind)
        self._changed()

    def request_sent(self, text: str, room: int, deliver_to: int) -> None:
        self._say("request_sent", text, room, deliver_to)
        self._start_goal(room)
        self._changed()

    def request_answered(self, accepted: bool) -> None:
        """Accepted: the dialog stays with its Close button; declined: it goes."""
        if not accepted:
            self.shown_request = None
        self._say("request_accepted" if accepted else "request_declined")
        self._changed()

    def request_closed(self) -> None:
        if self.shown_request is not None:
            self.shown_request = None
            self._changed()

    def not_sent(self) -> None:
        self._say("not_sent", error=True)
        self._changed()

    # ------------------------------------------------------------------ goal progress
    def _start_goal(self, room: int) -> None:
        self.tour_stop = None
        self.goal = GoalProgress(room)
        self._update_progress()

    def _update_progress(self) -> None:
        goal = self.goal
        if goal is None or self.pose is None:
            return
        xy = self.room_xy(goal.room)
        if xy is None:
            return
        distance = math.hypot(xy[0] - self.pose[0], xy[1] - self.pose[1])
        if goal.start_distance is None or distance > goal.start_distance:
            goal.start_distance = distance
        start = goal.start_distance
        goal.progress = 100 if start < 1e-6 else round(100.0 * (1.0 - distance / start))


def _distance_in(text: str) -> float | None:
    """The metres in the station's "…, 12.3 m to the next goal" (None when absent)."""
    words = text.split()
    for word, unit in itertools.pairwise(words):
        if unit == "m":
            try:
                return float(word)
            except ValueError:
                return None
    return None


# Built once (not per message): the handler of each station message type but GoalStatus.
_HANDLERS: Final[dict[type, Callable[[TabletSession, Any], None]]] = {
    Pose: TabletSession.on_pose,
    InitialPose: TabletSession.on_initial_pose,
    Localisation: TabletSession.on_localisation,
    TourState: TabletSession.on_tour_state,
    ShowRequest: TabletSession.on_show_request,
    Cancel: TabletSession.on_cancel,
    Permissions: TabletSession.on_permissions,
    StatusInfo: TabletSession.on_status,
    ErrorReport: TabletSession.on_error,
}
