"""The kidnapped robot on the full stack, on simulated time (thesis §3.2, §5.2.2.1 "Help me!").

`SimulatedSystem` runs the simulator, the `RobotStack` (localiser, navigator, multiplexer) and
the station's supervisor on one clock. While the robot drives a route, the simulated robot is
teleported several metres (odometry does not notice): the localiser must report ``lost`` within
2 s of simulated time, the motors must get zero from then on, and after a new initial pose at
the robot's true pose it must be ``ok`` again and finish the route.
"""

from __future__ import annotations

import math

from interbot_core.geometry import Pose2D
from interbot_core.topics import RouteMsg
from robot_daemon.localisation.localiser import LocaliserState
from robot_daemon.scenarios.runner import ScenarioOptions, SimulatedSystem

ROUTE_ID = 1
GOAL_NODE = 2  # Secretariat, via node 1 (SW corner): down the west corridor from node 0
KIDNAP_POSE = Pose2D(-29.4, -2.5, 0.0)  # further down the corridor, turned 90 degrees
LOST_WITHIN = 2.0  # [s] of simulated time


def test_kidnapped_robot_is_lost_within_2s_stops_and_recovers_after_a_new_initial_pose() -> None:
    system = SimulatedSystem(ScenarioOptions(seed=5, people=0, odometry="calibrated"))
    stack, sim = system.stack, system.sim
    system.localise()
    pose = stack.pose
    assert pose is not None
    route = system.route_planner.plan(pose, GOAL_NODE)
    waypoints = tuple((w.x, w.y, w.yaw) for w in route.waypoints)
    stack.set_route(RouteMsg(ROUTE_ID, waypoints, route.node_ids), system.now)

    # Drive about 2.7 m down the corridor, localised, under the planner's command.
    assert system.run_until(lambda: sim.true_pose().y < 1.0, 60.0), "the robot never set off"
    assert stack.localisation_state == LocaliserState.OK
    assert stack.last_output.source == "Planner" and stack.last_output.linear > 0.1
    before = sim.true_pose()
    assert before.distance_to(KIDNAP_POSE) > 3.0  # several metres
    stack.drain_events()

    sim.teleport(KIDNAP_POSE)
    kidnapped_at = system.now
    assert system.run_until(lambda: stack.localisation_state == LocaliserState.LOST, 5.0)
    lost_at = system.now
    assert lost_at - kidnapped_at <= LOST_WITHIN
    events = stack.drain_events()
    assert any(e.level == "error" and e.text == "localisation lost" for e in events)

    # From the step that reports lost on, the motors get zero: autonomous motion stops.
    outputs: list[tuple[float, float]] = []

    def record() -> bool:
        outputs.append((stack.last_output.linear, stack.last_output.angular))
        return stack.localisation_state != LocaliserState.LOST

    assert (stack.last_output.linear, stack.last_output.angular) == (0.0, 0.0)
    assert not system.run_until(record, 3.0), "lost must persist until a new initial pose"
    assert outputs and all(out == (0.0, 0.0) for out in outputs)
    assert sim.true_velocity() == (0.0, 0.0)
    assert stack.route is not None and stack.route.state == "paused"
    assert "localisation lost" in (stack.suspended_reason or "")

    # The user tells the robot where it is (the true pose): ok again, and the route completes.
    stopped = sim.true_pose()
    assert stopped.distance_to(KIDNAP_POSE) < 0.5  # it stopped near where it was put
    stack.set_initial_pose(stopped, system.now)
    states: set[LocaliserState] = set()

    def finished() -> bool:
        states.add(stack.localisation_state)
        return stack.route is not None and stack.route.finished

    assert system.run_until(finished, 120.0), "the route did not finish after the new pose"
    assert states == {LocaliserState.OK}
    assert stack.route is not None and stack.route.state == "succeeded"
    goal = system.topo.node(GOAL_NODE).pose
    end = sim.true_pose()
    assert end.distance_to(goal) < 0.4
    assert abs(math.remainder(end.yaw - goal.yaw, math.tau)) < 0.4
    estimate = stack.pose
    assert estimate is not None and estimate.distance_to(end) < 0.2
