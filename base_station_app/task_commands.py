"""The operator's and the tablet's commands on the commanded robot's tasks (thesis §5.3.3).

Queue a task (a rejected one is logged, and told to the tablet if it asked), reorder, remove,
clear, cancel, pause and resume, leave or end a tour stop, answer a request shown at a room,
resume a queue held by a stop; stop whatever the robot does (its task, a route nobody here
started, the tablet's driving); give it an initial pose, exact or by room, or ask it to find
itself. Each acts on the selected robot's `Supervisor` and hands the events to
`SupervisorEvents`; `TabletPolicy` says which tasks the tablet owns (a tablet's task cancelled
by someone else tells the tablet). `TabletRequests` reaches the station through this object.
Plain Python.
"""

from __future__ import annotations

from collections.abc import Callable

from base_station_app.fleet import Fleet
from base_station_app.fleet_link import FleetLink
from base_station_app.supervisor_events import Notices, SupervisorEvents
from base_station_app.tablet_policy import TabletPolicy
from base_station_app.tablet_session import describe_task
from interbot_core import protocol as p
from interbot_core.geometry import Pose2D
from interbot_core.supervisor import Event, SupervisorError, Task, TaskRejectedError
from interbot_core.topics import InitialPose, Relocalise, RouteCancel, Topic
from interbot_core.topological_map import TopologicalMap

#: [s] after an initial pose is sent, the robot's "unset"/"lost" is not passed on to the tablet
#: (the localiser applies the pose at its next scan, well within this at 10-40 Hz).
INITIAL_POSE_SETTLE_S = 2.0


class TaskCommands:
    """Commands on the selected robot's tasks and pose (see the module docstring)."""

    def __init__(
        self,
        fleet: Fleet,
        events: SupervisorEvents,
        robot_link: FleetLink,
        policy: TabletPolicy,
        tablet_send: Callable[[p.StationMessage], object],
        stop_tablet_speed: Callable[[str], object],
        topo: TopologicalMap,
        notices: Notices,
        clock: Callable[[], float],
    ) -> None:
        self._fleet, self._events, self._link, self._policy = fleet, events, robot_link, policy
        self._tablet_send, self._stop_speed, self._topo = tablet_send, stop_tablet_speed, topo
        self._notices, self._clock = notices, clock
        self._names = {n.id: n.name for n in topo.nodes}

    @property
    def robot_online(self) -> bool:
        return self._link.robot_online

    @property
    def estop_latched(self) -> bool:
        return self._link.estop_latched

    def log(self, level: str, text: str) -> None:
        self._notices.log(level, text)

    def submit(self, task: Task, *, from_tablet: bool = False) -> bool:
        """Queue a task for the selected robot; False (and a logged reason) if the map rejects it."""
        try:
            events = self._fleet.selected.supervisor.submit(task)
        except TaskRejectedError as exc:
            self.log("error", f"task rejected: {exc}")
            if from_tablet:
                self._tablet_send(p.ErrorReport("task_rejected", str(exc)[:500]))
            return False
        if from_tablet:
            self._policy.adopt(task)
        self.log("info", f"queued: {describe_task(task, self._names)}")
        self._events.handle(events)
        self._notices.tasks_changed()
        return True

    def _try(self, action: Callable[[], list[Event]]) -> bool:
        try:
            events = action()
        except SupervisorError as exc:
            self.log("warning", str(exc))
            return False
        self._events.handle(events)
        self._notices.tasks_changed()
        return True

    def cancel_task(self, who: str = "the operator") -> bool:
        """Cancel the running task; a tablet's task cancelled by someone else tells the tablet."""
        supervisor = self._fleet.selected.supervisor
        tablets = self._policy.owns(supervisor.current_task)
        cancelled = self._try(supervisor.cancel)
        if cancelled and tablets and who != "the tablet":
            self._tablet_send(p.Cancel(f"cancelled by {who}"))
        return cancelled

    def stop_motion(self, who: str) -> None:
        """Stop whatever runs: the task (if any), a route this station did not start, teleop."""
        robot = self._fleet.selected
        if robot.supervisor.current_task is not None:
            self.cancel_task(who)
        if robot.route_mirror.robot_running and robot.route is None:
            # A route from before a station restart (or one we lost track of): cancel it too.
            cancel = RouteCancel(None, f"stopped by {who}", stamp=self._clock())
            self._link.send(Topic.ROUTE_CANCEL, cancel)
            robot.route_mirror.foreign = None
            self.log("warning", f"{who}: cancelled the robot's route")
        self._stop_speed(f"stop from {who}")

    def stop_tablet_speed(self, why: str) -> None:
        """Forget the tablet's command and send one explicit zero if one was forwarded."""
        self._stop_speed(why)

    def move_task(self, index: int, delta: int) -> bool:
        supervisor, target = self._fleet.selected.supervisor, index + delta
        if not 0 <= target < len(supervisor.queue):
            return False
        return self._try(lambda: supervisor.reorder(index, target))

    def remove_task(self, index: int) -> bool:
        supervisor = self._fleet.selected.supervisor
        return self._try(lambda: supervisor.remove(index))

    def clear_queue(self) -> bool:
        return self._try(self._fleet.selected.supervisor.clear_queue)

    def pause(self) -> None:
        self._events.handle(self._fleet.selected.supervisor.pause())

    def resume(self) -> None:
        self._events.handle(self._fleet.selected.supervisor.resume())

    def tour_resume(self) -> bool:
        """Leave the tour stop: release the pause and drive to the next stop."""
        ok = self._try(self._fleet.selected.supervisor.tour_resume)
        if ok:
            self._fleet.selected.goal_reached = False
            self.resume()
        return ok

    def tour_end(self) -> bool:
        ok = self._try(self._fleet.selected.supervisor.tour_end)
        if ok:
            self.resume()
        return ok

    def answer_request(self, accepted: bool) -> bool:
        supervisor = self._fleet.selected.supervisor
        return self._try(lambda: supervisor.request_response(accepted))

    def resume_queue(self) -> None:
        """The operator's "Resume queue": waiting tasks may start again (not during a stop).

        It applies to the selected robot; another robot's queue is resumed when it is selected.
        """
        if self._link.estop_latched:
            self.log("warning", "release the emergency stop before resuming the queue")
            return
        supervisor = self._fleet.selected.supervisor
        if supervisor.held:
            self._events.handle(supervisor.release_queue())
            self.log("info", "task queue resumed by the operator")

    def set_initial_pose(self, pose: Pose2D, verify: bool = False) -> None:
        """``verify``: a room rather than an exact pose; the robot confirms it by laser."""
        now = self._clock()
        msg = InitialPose(pose.x, pose.y, pose.yaw, stamp=now, verify=verify)
        self._link.send(Topic.INITIAL_POSE, msg)
        # Until the robot reports the pose applied, its last "unset"/"lost" is stale: holding
        # it back keeps the tablet's "Help me!" banner from flashing up again (and the state is
        # said afresh once the robot answers or the grace runs out: tablet_feed.py).
        self._fleet.selected.pose_settling_until = now + INITIAL_POSE_SETTLE_S
        self.log("info", f"initial pose set to ({pose.x:.2f}, {pose.y:.2f}, {pose.yaw:.2f} rad)")

    def set_initial_pose_room(self, node_id: int) -> None:
        self.set_initial_pose(self._topo.node(node_id, "room").pose, verify=True)

    def relocalise(self) -> None:
        """Ask the robot to find itself on the whole map (global localisation)."""
        self._link.send(Topic.RELOCALISE, Relocalise(stamp=self._clock()))
        self.log("info", "relocalisation requested")
