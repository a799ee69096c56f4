"""``interbot scenario … --record FILE.mcap``: a headless run recorded like the daemon records.

`ScenarioRecorder.sample` is called after every step of a `SimulatedSystem` and offers the
recorder what the daemon would publish, at the daemon's rates on simulated time (pose, odometry,
cmd_vel and the mux at 20 Hz, scans at 10 Hz, the battery at 1 Hz, route progress on change),
the stack's status events, the station's supervisor events as ``/tasks`` (who asked for what),
the robot's planned path (its ``plan`` topic), the routes and pause locks the station sent as
``/commands`` — and, on its own ``/truth``
channel, the simulator's true pose and collision count, which never reach the robot.

A scenario may build several systems one after the other (each restarting at t = 0): each is
recorded after the previous one, one second later, so the file's times keep increasing.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from interbot_core.supervisor import PauseNavigation, RouteCancelled
from interbot_core.topics import (
    Battery,
    Status,
    Topic,
)
from robot_daemon.daemon import current_plan, publish_state, route_progress
from robot_daemon.recording.recorder import Recorder
from robot_daemon.stack import Periodic

if TYPE_CHECKING:
    from robot_daemon.scenarios.runner import SimulatedSystem

SCENARIO = "station (scenario)"
TRUTH = "/truth"
TASKS = "/tasks"
RATES_HZ = {"state": 20.0, "scan": 10.0, "battery": 1.0}  # the daemon's rates


class ScenarioRecorder:
    """Samples simulated systems into one MCAP file (``path``)."""

    def __init__(self, path: Path, *, epoch_offset: float = 0.0, robot_id: str = "sim") -> None:
        self.recorder = Recorder(
            robot_id, single_file=path, epoch_offset=epoch_offset, queue_size=100_000
        )
        self._offset = 0.0  # [s] file time of the current system's t = 0
        self._end = 0.0
        self._system: SimulatedSystem | None = None

    def attach(self, system: SimulatedSystem) -> None:
        """Start recording ``system`` (after whatever was recorded before)."""
        self._offset = self._end + 1.0 if self._system is not None else 0.0
        self._system = system
        self._due = {name: Periodic(hz) for name, hz in RATES_HZ.items()}
        self._events_seen = 0
        self._route_key: tuple[int, int, str] | None = None
        self._route_id: int | None = None
        self._plan: tuple[int, tuple[tuple[float, float], ...]] | None = None
        self.recorder.state(Topic.MAP, system.grid, self._offset + system.now)

    def sample(self, system: SimulatedSystem) -> None:
        if system is not self._system:
            self.attach(system)
        stack, rec = system.stack, self.recorder
        t = self._offset + system.now
        self._end = t
        due = self._due
        if due["state"](system.now):
            publish_state(stack, t, lambda topic, message: rec.state(topic, message, t))
            truth = system.sim.true_pose()
            linear, angular = system.sim.true_velocity()
            rec.json(
                TRUTH,
                {
                    "x": truth.x,
                    "y": truth.y,
                    "yaw": truth.yaw,
                    "linear": linear,
                    "angular": angular,
                    "collisions": system.sim.collisions,
                    "stamp": t,
                },
                t,
            )
            plan = current_plan(stack, t)
            if (plan.route_id, plan.points) != self._plan:  # replayed, and /planned_path
                self._plan = (plan.route_id, plan.points)
                rec.state(Topic.PLAN, plan, t)
        if due["scan"](system.now) and stack.last_scan is not None:
            rec.state(Topic.SCAN, stack.last_scan, t)
        if due["battery"](system.now) and stack.last_battery is not None:
            b = stack.last_battery
            rec.state(Topic.BATTERY, Battery(b.voltage, b.current, b.state_of_charge, t), t)
        self._sample_route(system, t)
        for line in stack.drain_events():
            rec.state(Topic.STATUS, Status(line.level, line.text, stamp=t), t)
        for _, event in system.events[self._events_seen :]:
            if isinstance(event, PauseNavigation):
                rec.command(Topic.PAUSE_NAV, {"engaged": event.paused}, t, source=SCENARIO)
            elif isinstance(event, RouteCancelled):
                rec.command(Topic.ROUTE_CANCEL, {"reason": event.reason}, t, source=SCENARIO)
            rec.json(
                TASKS, {"event": type(event).__name__, "detail": _event_dict(event), "stamp": t}, t
            )
        self._events_seen = len(system.events)

    def _sample_route(self, system: SimulatedSystem, t: float) -> None:
        stack, rec = system.stack, self.recorder
        route = stack.route
        if route is not None and route.route_id != self._route_id:
            self._route_id = route.route_id
            rec.command(Topic.ROUTE, route.msg, t, source=SCENARIO)
        if route is not None:
            key = (route.route_id, route.index, route.state)
            if key != self._route_key:
                self._route_key = key
                rec.state(Topic.ROUTE_PROGRESS, route_progress(route, route.reason, t), t)

    def close(self) -> None:
        self.recorder.close()

    def __enter__(self) -> ScenarioRecorder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _event_dict(event: object) -> Any:
    from robot_daemon.recording.recorder import message_dict

    try:
        return message_dict(event)
    except TypeError:
        return repr(event)
