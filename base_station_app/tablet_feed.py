"""What the station tells the tablet each ``clock()`` (thesis §5.3.2, §5.3.6 "communication").

The tablet is bound to the robot the operator commands. Each clock the station sends it, for that
robot: ``initial_pose: false`` until the robot is localised, then its ``pose``; the localisation
state when it changes (held back for `settle` seconds after an initial pose, so a stale
"unset"/"lost" does not flash the "Help me!" banner again); the collision monitor's zone when it
changes; the current ``goal`` with its ``reached`` / ``tourReached`` flags; the tour state when it
changes (an ended tour is said too: no stale highlight); and the task and status text when they
change. While the robot is offline: only the status ("robot offline"), never a stale pose.

`TabletFeed` remembers what was said so that changes only are repeated; `forget` makes it say
everything afresh (a tablet connected, another robot selected), and a new initial pose (the
robot's ``pose_settling_until`` moved) the localisation state. Plain Python.
"""

from __future__ import annotations

from base_station_app.robot_mirror import RobotMirror
from interbot_core import protocol as p
from interbot_core.supervisor import SupervisorState


class TabletFeed:
    """The messages of the communication section, changes only (see the module docstring)."""

    def __init__(self) -> None:
        self.forget()

    def forget(self) -> None:
        """Say everything again at the next clock."""
        self.localisation_sent: str | None = None
        self.settling_until = -1.0  # [s] the robot's grace after an initial pose, last seen
        self.tour_state_sent: p.TourState | None = None
        self.status_sent: p.StatusInfo | None = None
        self.safety_sent: p.SafetyInfo | None = None

    def _status(self, status: p.StatusInfo) -> list[p.StationMessage]:
        if status == self.status_sent:
            return []
        self.status_sent = status
        return [status]

    def messages(
        self, robot: RobotMirror, now: float, online: bool, status: p.StatusInfo
    ) -> list[p.StationMessage]:
        """This clock's messages for the tablet about ``robot`` (``status``: task and status)."""
        if robot.pose_settling_until != self.settling_until:  # an initial pose was sent
            self.settling_until, self.localisation_sent = robot.pose_settling_until, None
        if not online:
            self.localisation_sent = None
            return self._status(status)
        out: list[p.StationMessage] = []
        state, sup = robot.state, robot.supervisor
        loc = state.localisation
        settling = loc in ("unset", "lost") and now < robot.pose_settling_until
        if loc != self.localisation_sent and not settling:
            out.append(p.Localisation(loc))
            self.localisation_sent = loc
        safety = state.safety
        if safety is not None:  # the collision monitor, for the person at the joystick
            info = p.SafetyInfo(
                safety.zone, round(safety.distance, 2), "tablet_vel" in safety.assisted
            )
            if info != self.safety_sent:
                out.append(info)
                self.safety_sent = info
        pose = state.localised_pose
        if state.pose is None or state.pose.state == "unset":
            if not settling:
                out.append(p.InitialPose(False))
        elif pose is not None:
            out.append(p.Pose(pose.x, pose.y, pose.yaw))
        goal = sup.current_goal_node
        if goal is not None:
            at_stop = sup.state is SupervisorState.AT_TOUR_STOP
            out.append(p.GoalStatus(goal, robot.goal_reached, at_stop))
        tour = (
            p.TourState(sup.tour_stops, sup.visited_tour_stops, sup.next_tour_stop)
            if sup.tour_stops
            else None
        )
        if tour != self.tour_state_sent:
            out.append(tour if tour is not None else p.TourState((), (), None))
        self.tour_state_sent = tour
        return out + self._status(status)
