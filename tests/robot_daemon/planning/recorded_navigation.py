"""A simulated robot's navigation inputs, recorded to replay through other navigators.

The realistic world's guided tour (`robot_daemon.scenarios.tour`, people walking) is run for a
few hundred loop steps and every call the stack makes on its navigator is kept: routes,
cancellations and the control cycles with their pose and scan. Replayed open loop, they give
a navigator the very inputs the robot gave this one.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import LaserScan
from interbot_core.occupancy_grid import OccupancyGrid
from interbot_core.supervisor import GuidedTour
from robot_daemon.planning.config import PlannerConfig
from robot_daemon.planning.navigator import NavCommand, Navigator
from robot_daemon.scenarios.runner import ScenarioOptions, SimulatedSystem, auto_resume_tour
from robot_daemon.scenarios.tour import STOP_DWELL_S


@dataclass
class RecordedNavigation:
    grid: OccupancyGrid
    config: PlannerConfig
    # ("route", args, kwargs) | ("cancel", (), {}) | ("update", (now, pose, scan), {})
    calls: list[tuple[str, tuple[Any, ...], dict[str, Any]]] = field(default_factory=list)
    commands: list[NavCommand] = field(default_factory=list)  # what the robot's navigator said

    def replay(self, navigator: Navigator) -> list[NavCommand]:
        """Every command ``navigator`` gives for the recorded calls."""
        out = []
        for name, args, kwargs in self.calls:
            if name == "route":
                navigator.set_route(*args, **kwargs)
            elif name == "cancel":
                navigator.cancel()
            else:
                out.append(navigator.update(*args))
        return out


def record_tour(
    steps: int, seed: int = 1, people: int = 4
) -> tuple[SimulatedSystem, RecordedNavigation]:
    """Run the tour's first ``steps`` loop steps, recording the navigator's calls."""
    system = SimulatedSystem(ScenarioOptions(seed=seed, people=people))
    navigator = system.stack.navigator
    record = RecordedNavigation(system.grid, navigator.config)
    set_route, cancel, update = navigator.set_route, navigator.cancel, navigator.update

    def recording_set_route(poses: Sequence[Pose2D], *args: Any, **kwargs: Any) -> None:
        record.calls.append(("route", (tuple(poses), *args), dict(kwargs)))
        set_route(poses, *args, **kwargs)

    def recording_cancel() -> None:
        record.calls.append(("cancel", (), {}))
        cancel()

    def recording_update(now: float, pose: Pose2D, scan: LaserScan | None = None) -> NavCommand:
        record.calls.append(("update", (now, pose, scan), {}))
        command = update(now, pose, scan)
        record.commands.append(command)
        return command

    navigator.set_route = recording_set_route  # type: ignore[method-assign]
    navigator.cancel = recording_cancel  # type: ignore[method-assign]
    navigator.update = recording_update  # type: ignore[method-assign]
    system.hooks.append(auto_resume_tour(STOP_DWELL_S))
    system.localise()
    system.apply(system.supervisor.submit(GuidedTour()))
    for _ in range(steps):
        system.step()
    return system, record
