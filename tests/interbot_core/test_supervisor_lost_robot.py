"""A lost robot gets its next leg as the goal alone (issue 16, `Supervisor.update`).

The robot owns its localisation and its route: a robot that lost the pose it had and looks for
it again is sent the leg that is due (the goal node's pose, one waypoint), which it plans to
from the pose it finds; the station sends nothing more. Never to a robot that never had a pose
(thesis §5.2.2.1), nor while it is disconnected, stopped, paused or the queue is held.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from interbot_core.geometry import Pose2D
from interbot_core.route_planner import RoutePlanner
from interbot_core.supervisor import (
    Delivery,
    GoTo,
    GoToPose,
    GuidedTour,
    QueueChanged,
    RobotCondition,
    RouteStarted,
    Supervisor,
    SupervisorState,
    TaskStarted,
    TourStopReached,
)
from interbot_core.topological_map import TopologicalMap, load_topological_map

FIXTURE = Path(__file__).parent / "data" / "tiny_topo.yaml"
FINDING = RobotCondition(connected=True, stopped=False, finding=True)


@pytest.fixture
def topo() -> TopologicalMap:
    return load_topological_map(FIXTURE)


@pytest.fixture
def sup(topo: TopologicalMap) -> Supervisor:
    return Supervisor(topo, RoutePlanner(topo))


def at_first_tour_stop(sup: Supervisor) -> None:
    """A tour waiting at its first stop (node 0, where the robot stands localised)."""
    sup.submit(GuidedTour())
    sup.update(0.1, Pose2D(0.0, 0.0, 0.0))
    (route,) = [sup.current_route]
    assert route is not None and route.final_node == 0
    events = sup.robot_route_succeeded(0.2)
    assert isinstance(events[-1], TourStopReached) and sup.state is SupervisorState.AT_TOUR_STOP


def test_the_tours_next_leg_goes_to_a_lost_robot_as_the_goal_alone(
    sup: Supervisor, topo: TopologicalMap
) -> None:
    at_first_tour_stop(sup)
    sup.tour_resume()
    goal = topo.node(1).pose
    assert sup.update(1.0, None, FINDING) == [RouteStarted((goal,), (1,), 1)]
    # Shown as waiting for the robot to find itself, not as driving, and no distance from a
    # pose the robot no longer vouches for.
    assert sup.state is SupervisorState.WAITING_FOR_POSE
    assert sup.distance_to_next_goal is None
    # Found: nothing is re-sent; the robot plans from the pose it found and reports.
    assert sup.update(1.1, Pose2D(30.0, 5.0, 0.0), FINDING) == []
    assert sup.state is SupervisorState.NAVIGATING
    assert sup.distance_to_next_goal == pytest.approx(Pose2D(30.0, 5.0, 0.0).distance_to(goal))
    events = sup.robot_route_succeeded(2.0)
    assert [type(e) for e in events] == [TourStopReached] and events[0].node == 1


def test_a_lost_robot_hears_of_its_leg_once(sup: Supervisor) -> None:
    at_first_tour_stop(sup)
    sup.tour_resume()
    assert len(sup.update(1.0, None, FINDING)) == 1
    for t in (1.1, 1.2, 1.3):  # still looking, then found, then lost again: nothing more
        assert sup.update(t, None, FINDING) == []
    assert sup.update(1.4, Pose2D(10.0, 0.0, 0.0), FINDING) == []
    assert sup.update(1.5, None, FINDING) == []


def test_a_queued_task_starts_for_a_lost_robot(sup: Supervisor, topo: TopologicalMap) -> None:
    sup.update(0.0, Pose2D(0.0, 0.0, 0.0))  # it had a pose
    sup.submit(GoTo(3))
    events = sup.update(1.0, None, FINDING)
    assert events == [
        TaskStarted(GoTo(3)),
        QueueChanged(()),
        RouteStarted((topo.node(3).pose,), (3,), 3),
    ]


def test_a_tour_queued_for_a_lost_robot_starts_nearest_its_last_pose(
    topo: TopologicalMap,
) -> None:
    sup = Supervisor(topo, RoutePlanner(topo))
    sup.update(0.0, Pose2D(19.0, 0.5, 0.0))  # last seen beside node 2
    sup.submit(GuidedTour())
    events = sup.update(1.0, None, FINDING)
    assert events[-1] == RouteStarted((topo.node(2).pose,), (2,), 2)
    assert sup.tour_stops == (2, 4, 0, 1)
    # A station that never saw a pose has no order for the tour: it waits.
    fresh = Supervisor(topo, RoutePlanner(topo))
    fresh.submit(GuidedTour())
    assert fresh.update(1.0, None, FINDING) == []
    assert fresh.state is SupervisorState.WAITING_FOR_POSE


def test_a_delivery_leg_and_a_free_pose_go_as_their_goal(
    sup: Supervisor, topo: TopologicalMap
) -> None:
    sup.update(0.0, Pose2D(0.0, 0.0, 0.0))
    sup.submit(Delivery("coffee", room=1, deliver_to=4))
    sup.update(0.1, Pose2D(0.0, 0.0, 0.0))
    sup.robot_route_succeeded(0.2)
    assert sup.state is SupervisorState.AWAITING_RESPONSE
    sup.request_response(True)
    assert sup.update(1.0, None, FINDING) == [RouteStarted((topo.node(4).pose,), (4,), 4)]
    sup.cancel()
    target = Pose2D(3.0, 4.0, 1.0)
    sup.submit(GoToPose(target))
    assert sup.update(2.0, None, FINDING)[-1] == RouteStarted((target,), (None,), None)


@pytest.mark.parametrize(
    "robot",
    [
        None,  # a caller that says nothing of the robot: tasks wait for a pose (as before)
        RobotCondition(connected=False, stopped=False, finding=True),
        RobotCondition(connected=True, stopped=True, finding=True),
        # never had a pose: unset, or the start-up search (thesis §5.2.2.1)
        RobotCondition(connected=True, stopped=False, finding=False),
    ],
    ids=["no-condition", "disconnected", "stopped", "start-up"],
)
def test_no_leg_goes_to_a_robot_that_may_not_take_one(
    sup: Supervisor, robot: RobotCondition | None
) -> None:
    at_first_tour_stop(sup)
    sup.tour_resume()
    sup.submit(GoTo(3))
    assert sup.update(1.0, None, robot) == []
    assert sup.state is SupervisorState.WAITING_FOR_POSE and sup.current_route is not None
    assert sup.current_route.final_node == 0  # still the route to the stop it stands at
    # Once it may, the leg goes (once).
    assert len(sup.update(1.1, None, FINDING)) == 1


def test_no_leg_while_paused_or_held(sup: Supervisor) -> None:
    at_first_tour_stop(sup)  # the station pauses navigation at a stop
    sup.pause()
    sup.tour_resume()
    assert sup.update(1.0, None, FINDING) == []
    sup.resume()
    sup.hold_queue()  # after an emergency stop
    assert sup.update(1.1, None, FINDING) == []
    sup.release_queue()
    assert [type(e) for e in sup.update(1.2, None, FINDING)] == [RouteStarted]
    # A queued task waits while held too.
    sup.cancel()
    sup.submit(GoTo(3))
    sup.hold_queue()
    assert sup.update(1.3, None, FINDING) == []
    assert sup.queue == (GoTo(3),)
