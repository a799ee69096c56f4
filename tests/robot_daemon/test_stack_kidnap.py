"""The kidnapped robot on the full stack, on simulated time (thesis §3.2, §5.2.2.1 "Help me!").

`SimulatedSystem` runs the simulator, the `RobotStack` (localiser, navigator, multiplexer) and
the station's supervisor on one clock. While the robot drives a route, the simulated robot is
teleported several metres (odometry does not notice): the robot must stop being ``ok`` (lost or
searching) within 2 s of simulated time, must not drive from then on (it may turn in place to
look around), and must find itself again by the global search (issue 16), at the truth, and
finish the route. A "Help me!"
pose far from the truth is refused; one at the truth is confirmed."""

from __future__ import annotations

import math

from msgspec.structs import replace

from interbot_core.geometry import Pose2D
from robot_daemon.localisation.localiser import LocaliserState
from robot_daemon.scenarios.runner import ScenarioOptions, SimulatedSystem
from tests.robot_daemon.stack_route import localise_and_send_route

ROUTE_ID = 1

GOAL_NODE = 2  # Secretariat, via node 1 (SW corner): down the west corridor from node 0
KIDNAP_POSE = Pose2D(-29.4, -2.5, 0.0)  # further down the corridor, turned 90 degrees
LOST_WITHIN = 2.0  # [s] of simulated time


def test_kidnapped_robot_is_lost_within_2s_stops_and_recovers_after_a_new_initial_pose() -> None:
    # World = map: the detection and search mechanics. In the realistic world (issue 12) this
    # spot has a mirror image: the corridor 63 m east fits its scan as well (quality 0.98 vs
    # 0.94 at the truth), so the robot rightly stays undecided there and asks for help; the
    # realistic world is relocalised in `interbot scenario kidnap` and the start-up test.
    system = SimulatedSystem(
        ScenarioOptions(seed=5, people=0, odometry="calibrated", ideal_world=True)
    )
    stack, sim = system.stack, system.sim
    localise_and_send_route(system, GOAL_NODE, ROUTE_ID)

    # Drive about 2.7 m down the corridor, localised, under the planner's command.
    assert system.run_until(lambda: sim.true_pose().y < 1.0, 60.0), "the robot never set off"
    assert stack.localisation_state == LocaliserState.OK
    assert stack.last_output.source == "Planner" and stack.last_output.linear > 0.1
    before = sim.true_pose()
    assert before.distance_to(KIDNAP_POSE) > 3.0  # several metres
    stack.drain_events()

    sim.teleport(KIDNAP_POSE)
    kidnapped_at = system.now
    # Degraded at once (a bad scan), then lost: the global search starts (issue 16).
    stopped = (LocaliserState.LOST, LocaliserState.SEARCHING)
    assert system.run_until(lambda: stack.localisation_state in stopped, 5.0)
    lost_at = system.now
    assert lost_at - kidnapped_at <= LOST_WITHIN
    events = stack.drain_events()
    assert any(e.level == "error" for e in events), events

    # From the step that reports not-ok on, the robot does not drive until it has found itself
    # again (issue 16: it searches the map by itself, turning in place; no person needed here).
    outputs: list[tuple[float, float]] = []
    seen: set[LocaliserState] = set()

    def record() -> bool:
        outputs.append((stack.last_output.linear, stack.last_output.angular))
        seen.add(stack.localisation_state)
        return stack.localisation_state == LocaliserState.OK

    assert (stack.last_output.linear, stack.last_output.angular) == (0.0, 0.0)
    assert system.run_until(record, 10.0), "the robot did not find itself within 10 s"
    # No translation while not localised; at most the look-around's slow turn in place.
    turn = stack.look_around.config.angular_speed
    assert all(linear == 0.0 and abs(angular) <= turn + 1e-9 for linear, angular in outputs[:-1])
    assert LocaliserState.SEARCHING in seen
    estimate = stack.pose
    assert estimate is not None and estimate.distance_to(sim.true_pose()) < 0.2
    assert sim.true_pose().distance_to(KIDNAP_POSE) < 0.5  # it stood where it was put

    # The route resumes from there and completes.
    states: set[LocaliserState] = set()

    def finished() -> bool:
        states.add(stack.localisation_state)
        return stack.route is not None and stack.route.finished

    assert system.run_until(finished, 120.0), "the route did not finish after relocalising"
    assert states == {LocaliserState.OK}
    assert stack.route is not None and stack.route.state == "succeeded"
    goal = system.topo.node(GOAL_NODE).pose
    end = sim.true_pose()
    assert end.distance_to(goal) < 0.4
    assert abs(math.remainder(end.yaw - goal.yaw, math.tau)) < 0.4
    estimate = stack.pose
    assert estimate is not None and estimate.distance_to(end) < 0.2


def test_help_me_pose_far_from_the_truth_is_rejected() -> None:
    """A "Help me!" pose in the wrong room is checked by the search around it and refused."""
    # World = map: the detection and search mechanics. In the realistic world (issue 12) this
    # spot has a mirror image: the corridor 63 m east fits its scan as well (quality 0.98 vs
    # 0.94 at the truth), so the robot rightly stays undecided there and asks for help; the
    # realistic world is relocalised in `interbot scenario kidnap` and the start-up test.
    system = SimulatedSystem(
        ScenarioOptions(seed=5, people=0, odometry="calibrated", ideal_world=True)
    )
    stack = system.stack
    cfg = stack.relocalisation.config
    stack.relocalisation.config = replace(cfg, on_unset=False, help_verify_s=2.0)
    truth = system.sim.true_pose()
    wrong = system.topo.node(8).pose
    assert wrong.distance_to(truth) > 15.0
    system.step()
    stack.set_initial_pose(wrong, system.now, verify=True)
    assert stack.localisation_state == LocaliserState.SEARCHING
    system.run_until(lambda: not stack.relocalisation.active, 4.0)
    assert not stack.relocalisation.active
    assert stack.localiser.state == LocaliserState.UNSET  # never trusted
    texts = [e.text for e in stack.drain_events()]
    assert any("does not match" in t for t in texts), texts

    # The same check around the right place confirms it.
    stack.set_initial_pose(truth, system.now, verify=True)
    assert system.run_until(lambda: stack.localisation_state == LocaliserState.OK, 4.0)
    estimate = stack.pose
    assert estimate is not None and estimate.distance_to(truth) < 0.2
