"""The stack while localisation is 'degraded': the route goes on at reduced speed (issue 12).

Degraded means tracking but uncertain (e.g. far along a featureless corridor) or the last scans
disagree with the map. The stack keeps driving the route at ``degraded_speed_scale`` of the
planner's linear speed (only motion brings new structure into view; bad scans turn degraded into
lost, a stop, within a second), tells the station why, and publishes the covariance.
"""

from __future__ import annotations

import numpy as np
import pytest

from robot_daemon.localisation.localiser import LocaliserConfig, LocaliserState
from robot_daemon.scenarios.runner import ScenarioOptions, SimulatedSystem
from robot_daemon.stack import StackConfig, StackError
from tests.robot_daemon.stack_route import localise_and_send_route

GOAL_NODE = 2  # Secretariat, via node 1: down the west corridor from node 0


def _drive(config: StackConfig, seconds: float) -> tuple[SimulatedSystem, list[float], set]:
    system = SimulatedSystem(ScenarioOptions(seed=5, people=0), stack_config=config)
    stack = system.stack
    localise_and_send_route(system, GOAL_NODE)
    speeds: list[float] = []
    states: set[LocaliserState] = set()

    def record() -> bool:
        speeds.append(stack.last_output.linear)
        states.add(stack.localisation_state)
        return False

    system.run_until(record, seconds)
    return system, speeds, states


def test_degraded_localisation_drives_the_route_at_half_speed() -> None:
    # A 1 mm threshold: every estimate is "uncertain", so the whole run is degraded.
    always_degraded = StackConfig(localiser=LocaliserConfig(degraded_sigma_m=0.001))
    system, speeds, states = _drive(always_degraded, 12.0)
    stack = system.stack
    max_speed = stack.config.planner.max_linear_speed
    assert states == {LocaliserState.DEGRADED}
    assert stack.route is not None and stack.route.state == "active"  # not suspended
    assert system.sim.true_pose().distance_to(system.start_pose) > 0.5  # it drives on
    assert max(speeds) <= 0.5 * max_speed + 1e-9
    assert max(speeds) > 0.3 * max_speed
    events = stack.drain_events()
    degraded = [e for e in events if e.text.startswith("localisation degraded")]
    assert degraded and degraded[0].level == "warning"
    assert "position uncertain" in degraded[0].text
    # The covariance the daemon publishes (base_link in map): symmetric, positive.
    cov = stack.pose_covariance
    assert cov.shape == (3, 3) and np.allclose(cov, cov.T)
    assert np.all(np.linalg.eigvalsh(cov) > 0.0)


def test_ok_localisation_drives_faster_than_degraded() -> None:
    system, speeds, states = _drive(StackConfig(), 12.0)
    assert LocaliserState.DEGRADED not in states and LocaliserState.LOST not in states
    assert max(speeds) > 0.6 * system.stack.config.planner.max_linear_speed


def test_bad_degraded_speed_scale_is_refused() -> None:
    with pytest.raises(StackError, match="degraded_speed_scale"):
        StackConfig(degraded_speed_scale=1.5)
