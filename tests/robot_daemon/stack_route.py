"""The route the station sends a simulated robot after localising it (stack tests)."""

from __future__ import annotations

from interbot_core.topics import RouteMsg
from robot_daemon.scenarios.runner import SimulatedSystem


def localise_and_send_route(system: SimulatedSystem, node_id: int, route_id: int = 1) -> None:
    """Set the initial pose, plan to topological node ``node_id`` from the map pose (as the
    daemon plans, `Daemon` route requests) and give the stack that route."""
    system.localise()
    pose = system.stack.map_pose
    assert pose is not None
    route = system.route_planner.plan(pose, node_id)
    waypoints = tuple((w.x, w.y, w.yaw) for w in route.waypoints)
    system.stack.set_route(RouteMsg(route_id, waypoints, route.node_ids), system.now)
