"""What a tablet's request becomes on the station: the tablet session's policy (issue 14).

The tablet is bound to the robot the operator commands (the selected one). A validated message
is first checked against `TabletPolicy` (the operator's permissions; nothing while the robot
is offline or the stop is engaged): a refusal is told to the tablet with its reason and
raises an alert. An allowed one becomes the operator command it asks for, with the tablet's
ownership rules: its Stop always stops the robot but cancels only what the tablet ordered (an
operator's task is paused, and the tablet told why); it answers only the request shown now.
The operator can take the tablet's task over, stop or cancel it.

Speed commands never come here on their way to the robot: they are forwarded in the tablet
thread (tablet_teleop.py). Plain Python: the station's commands are reached through
`TaskCommands`, the tablet through ``tablet_send``.
"""

from __future__ import annotations

from collections.abc import Callable

from base_station_app.alerts import AlertRules
from base_station_app.fleet import Fleet
from base_station_app.tablet_policy import TabletPolicy
from base_station_app.tablet_session import describe_task, permission_for
from base_station_app.task_commands import TaskCommands
from interbot_core import protocol as p
from interbot_core.supervisor import Delivery, GoHome, GoTo, GuidedTour, Task


class TabletRequests:
    """Turns the tablet's validated requests into station commands (see the module docstring)."""

    def __init__(
        self,
        policy: TabletPolicy,
        fleet: Fleet,
        station: TaskCommands,
        tablet_send: Callable[[p.StationMessage], object],
        alert_rules: AlertRules,
        names: dict[int, str],
        clock: Callable[[], float],
    ) -> None:
        self.policy, self._fleet, self._station = policy, fleet, station
        self._send, self._alert_rules = tablet_send, alert_rules
        self._names, self._clock = names, clock

    def on_message(self, msg: p.TabletMessage) -> None:
        """One validated request from the tablet (not a speed command), subject to permissions."""
        station, supervisor = self._station, self._fleet.selected.supervisor
        kind = permission_for(msg)
        why = self.policy.refusal(kind, station.robot_online, station.estop_latched)
        if why is not None:  # (a refused speed is told once per stream, in tablet_teleop.py)
            self._send(p.ErrorReport("not_permitted", why))
            station.log("warning", f"tablet {type(msg).__name__} refused: {kind} not allowed")
            self._alert_rules.on_refused(why, self._clock())
        elif isinstance(msg, p.Goal):
            station.submit(GoTo(msg.node), from_tablet=True)
        elif isinstance(msg, p.Home):
            station.submit(GoHome(), from_tablet=True)
        elif isinstance(msg, p.Pause):
            station.pause() if msg.paused else station.resume()
        elif isinstance(msg, p.Stop):
            if msg.stop:
                self.stop()
        elif isinstance(msg, p.Tour):
            if msg.start:
                station.submit(GuidedTour(), from_tablet=True)
            elif isinstance(supervisor.current_task, GuidedTour):
                station.tour_end()
        elif isinstance(msg, p.TourControl):
            station.tour_resume() if msg.action == "resume" else station.tour_end()
        elif isinstance(msg, p.RequestFrom):
            if msg.status:
                station.submit(Delivery(msg.request, msg.room, msg.deliver_to), from_tablet=True)
        elif isinstance(msg, p.RequestAnswer):
            shown = self._fleet.selected.shown_request
            if shown is not None and shown[0] == msg.id:
                station.answer_request(msg.accepted)
            else:
                self._send(p.ErrorReport("unknown_request", f"no request {msg.id} is shown"))
        elif isinstance(msg, p.InitialPoseRoom):
            station.set_initial_pose_room(msg.room)
        elif isinstance(msg, p.Malfunction):
            station.log("error", f"tablet reports {msg.kind}: {msg.text}")
            self._alert_rules.on_malfunction(msg.kind, msg.text, self._clock())

    def stop(self) -> None:
        """The tablet's Stop always stops the robot; it cancels only what the tablet ordered.

        An operator's task is paused instead (the robot stops, the task stays the operator's)
        and the tablet is told why; its own task, a route nobody here owns, or teleoperation
        is stopped outright.
        """
        station, task = self._station, self._fleet.selected.supervisor.current_task
        if task is not None and not self.policy.owns(task):
            station.log("warning", "tablet: stop on the operator's task: paused")
            station.pause()
            station.stop_tablet_speed("stop from the tablet")
            why = "paused: this task was given by the operator, who decides on it"
            self._send(p.ErrorReport("not_owner", why))
            return
        station.log("warning", "tablet: stop")
        station.stop_motion("the tablet")

    # ------------------------------------------------------------------ the operator's side
    @property
    def task(self) -> Task | None:
        """The selected robot's running task if the tablet ordered it."""
        task = self._fleet.selected.supervisor.current_task
        return task if self.policy.owns(task) else None

    def override(self) -> bool:
        """The operator takes the tablet's task over: it continues as a station task."""
        task = self.task
        if task is None:
            return False
        self.policy.forget(task)
        self._send(p.Cancel("task taken over by the operator"))
        self._station.log("info", f"operator took over: {describe_task(task, self._names)}")
        return True

    def stop_task(self) -> None:
        """Stop the tablet's task where it is (pause navigation; resume continues it)."""
        if self.task is not None:
            self._station.pause()

    def cancel_task(self) -> None:
        if self.task is not None:
            self._station.cancel_task()  # tells the tablet: cancelled by the operator
