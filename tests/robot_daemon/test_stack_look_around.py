"""Look around on the full stack (issue 16), on the realistic ISR world, simulated time.

The robot starts with its pose unset (and turns only when asked to "Relocalise": an idle robot
searches standing still) in the north-west corner of ISR's corridor ring, whose
scan from a standing robot fits the south-east corner 64 m away as well (quality 0.94 vs 0.89,
inside the decision's 0.1 margin). Turning in place it sees every heading, the truth explains
all the views clearly better, and it is accepted: at the truth, with only rotation commanded.
With the e-stop latched, or the look-around off, the robot never turns and stays undecided.
"""

from __future__ import annotations

import math

from interbot_core.geometry import Pose2D
from robot_daemon.localisation.localiser import LocaliserState
from robot_daemon.localisation.look_around import TURNING_TEXT, LookAroundConfig
from robot_daemon.scenarios.runner import ScenarioOptions, SimulatedSystem
from robot_daemon.stack import StackConfig

CORNER = Pose2D(-29.2, 11.2, -1.63)  # base_link, the north-west corner of the corridor ring


def _system(config: StackConfig | None = None) -> SimulatedSystem:
    return SimulatedSystem(
        ScenarioOptions(seed=2, people=0), start_pose=CORNER, stack_config=config
    )


def _outputs(system: SimulatedSystem, seconds: float) -> tuple[list[tuple[float, float]], bool]:
    """Motor commands over ``seconds`` (or until localised) and whether it localised."""
    stack = system.stack
    out: list[tuple[float, float]] = []

    def step() -> bool:
        out.append((stack.last_output.linear, stack.last_output.angular))
        return stack.localisation_state is LocaliserState.OK

    return out, system.run_until(step, seconds)


def test_an_idle_robot_searches_standing_still() -> None:
    """No route and no "Relocalise": nobody asked it to move, so it does not turn."""
    system = _system()
    outputs, found = _outputs(system, 6.0)
    assert not found  # standing, the corners stay look-alikes
    assert all(out == (0.0, 0.0) for out in outputs)
    assert system.stack.look_around.turns_started == 0


def test_a_robot_in_a_look_alike_corner_turns_and_finds_itself() -> None:
    """The operator's "Relocalise" is the command the turn serves."""
    system = _system()
    stack = system.stack
    system.step()
    stack.relocalise(system.now)
    outputs, found = _outputs(system, 15.0)
    assert found, stack.relocalisation.relocaliser.last_failure
    estimate = stack.pose
    truth = system.sim.true_pose()
    assert estimate is not None and estimate.distance_to(truth) < 0.15
    assert abs(math.remainder(estimate.yaw - truth.yaw, math.tau)) < 0.05
    assert all(linear == 0.0 for linear, _ in outputs)  # no translation, ever
    assert max(abs(angular) for _, angular in outputs) > 0.3  # it turned ...
    assert truth.distance_to(CORNER) < 0.1  # ... in place
    texts = [e.text for e in stack.drain_events()]
    assert TURNING_TEXT in texts  # the operator is told why it turns
    assert any(t.startswith("initial pose set to") for t in texts)
    # Found: the turn ends (no route: nothing moves it any more).
    system.run_until(lambda: False, 1.0)
    assert stack.last_output.angular == 0.0 and not stack.look_around.turning


def test_no_turning_while_the_emergency_stop_is_latched() -> None:
    system = _system()
    stack = system.stack
    stack.on_lock("stop", True, 0.0)
    stack.relocalise(0.0)
    outputs, found = _outputs(system, 6.0)
    assert not found  # standing, the corners stay look-alikes
    assert stack.localisation_state is LocaliserState.SEARCHING
    assert all(out == (0.0, 0.0) for out in outputs)
    assert stack.look_around.turns_started == 0
    assert system.sim.true_pose().distance_to(CORNER) < 1e-6
    # Released: this search attempt still does not turn by itself.
    stack.release_stop(system.now, "test")
    outputs, _ = _outputs(system, 2.0)
    assert all(out == (0.0, 0.0) for out in outputs) and stack.look_around.turns_started == 0


def test_no_turning_when_disabled() -> None:
    system = _system(StackConfig(look_around=LookAroundConfig(enabled=False)))
    stack = system.stack
    stack.relocalise(0.0)
    outputs, found = _outputs(system, 6.0)
    assert not found
    assert all(out == (0.0, 0.0) for out in outputs)
    assert stack.look_around.turns_started == 0


def test_no_turning_while_a_help_me_pose_is_checked() -> None:
    """The person who gave the pose stands at the tablet, on the robot: it keeps still."""
    system = _system()
    stack = system.stack
    system.step()
    stack.set_initial_pose(CORNER, system.now, verify=True)
    outputs, found = _outputs(system, 4.0)
    assert found, stack.relocalisation.relocaliser.last_failure  # the room settles it
    assert all(out == (0.0, 0.0) for out in outputs)
    assert stack.look_around.turns_started == 0


def test_the_robot_reports_turning_while_it_turns_to_find_itself() -> None:
    """What the station and tablet are told (`RobotStack.reported_localisation`): searching
    while it stands, turning while the look-around turns it, ok once found."""
    system = _system()
    stack = system.stack
    system.step()
    stack.relocalise(system.now)
    assert stack.reported_localisation == "searching"
    assert system.run_until(lambda: stack.look_around.turning, 3.0)
    assert stack.reported_localisation == "turning"
    assert stack.localisation_state is LocaliserState.SEARCHING  # the stack's own state
    assert system.run_until(lambda: stack.localisation_state is LocaliserState.OK, 15.0)
    assert stack.reported_localisation == "ok"
