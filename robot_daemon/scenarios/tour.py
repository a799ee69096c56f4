"""Test Scenario 2 (thesis §6.2, Table 6.4): the guided tour of the floor with people walking.

The robot starts at home, localised by the operator; the visitor asks for a guided tour; at each
stop the robot pauses, shows the room's information and the visitor taps Resume a few seconds
later. A localiser lost for 60 s with nobody to re-set the pose ends the tour as failed.
Figures come from the simulator's ground truth; the realtime factor is simulated time over wall
time for the whole stack (localiser, planner, multiplexer, simulator, supervisor);
``cpu_realtime_factor`` divides by the process's CPU time instead, which a shared machine's load
does not inflate (it is what a quiet machine's real-time factor would be).
"""

from __future__ import annotations

from typing import Any

from interbot_core.supervisor import GuidedTour, TaskFinished, TourStopReached
from robot_daemon.localisation.localiser import LocaliserState
from robot_daemon.localisation.wall_model import wall_model_figures
from robot_daemon.scenarios.runner import (
    ScenarioOptions,
    ScenarioResult,
    SimulatedSystem,
    auto_resume_tour,
)

STOP_DWELL_S = 5.0  # [s] the visitor reads the room's information, then taps Resume
LOST_GIVE_UP_S = 60.0  # [s] lost this long with nobody re-setting the pose: the tour has failed


def run(options: ScenarioOptions) -> ScenarioResult:
    system = SimulatedSystem(options)
    system.hooks.append(auto_resume_tour(STOP_DWELL_S))
    system.localise()
    system.apply(system.supervisor.submit(GuidedTour()))
    start = system.now
    lost_since: list[float] = []  # when the localiser last became lost (nobody re-localises)

    def done() -> bool:
        if system.stack.localisation_state == LocaliserState.LOST:
            if not lost_since:
                lost_since.append(system.now)
            return system.now - lost_since[0] >= LOST_GIVE_UP_S
        lost_since.clear()
        return bool(system.of(TaskFinished))

    completed = system.run_until(done)
    finished = system.of(TaskFinished)
    ok = bool(finished) and finished[0][1].ok
    if lost_since and not finished:
        reason = f"localisation lost at {lost_since[0]:.1f} s and not re-set by an operator"
    else:
        reason = finished[0][1].reason if finished else "time limit reached"
    stops = system.of(TourStopReached)
    total = len(system.supervisor.tour_stops) or len(system.topo.tour_nodes())
    duration = system.now - start
    figures = {
        "completed": bool(completed and ok),
        "reason": reason,
        "duration_s": round(duration, 1),
        "collisions": system.sim.collisions,
        "stops_visited": len(stops),
        "stops_total": total,
        "people": options.people,
        "seed": options.seed,
        "world": "ideal (world = map)" if options.ideal_world else "realistic",
        **system.metrics.figures(),
        **wall_model_figures(system.stack.localiser.wall_model),
        # the floor under the reported covariance, learnt from the corrections (`map_floor`)
        "loc_map_floor_m": round(system.stack.localiser.map_floor.sigma_m, 4),
        "loc_map_floor_windows": system.stack.localiser.map_floor.windows,
        "realtime_factor": round(system.realtime_factor(), 1),
        "cpu_realtime_factor": round(system.cpu_realtime_factor(), 1),
    }
    minutes, seconds = divmod(round(duration), 60)
    table = "\n".join(
        [
            "Test Scenario 2: guided tour (thesis Table 6.4)",
            "Duration  Success  Distance(m)  Collisions  Loc.losses  Mean linear speed (m/s)",
            f"{minutes:02d}:{seconds:02d}     {'YES' if figures['completed'] else 'NO ':<7}"
            f"  {figures['distance_m']:>11.2f}  {figures['collisions']:>10}"
            f"  {figures['localisation_losses']:>10}  {figures['mean_speed_mps']:>23.4f}",
            f"stops {len(stops)}/{total}; localisation RMS {figures['loc_rms_m'] * 100:.1f} cm, "
            f"max {figures['loc_max_m'] * 100:.1f} cm as reported (the map pose navigation "
            f"acts on: {figures['loc_map_pose_rms_m'] * 100:.1f} / "
            f"{figures['loc_map_pose_max_m'] * 100:.1f} cm); min clearance "
            f"{figures['min_clearance_m'] * 100:.1f} cm; corridor speed "
            f"{figures['corridor_speed_ratio'] * 100:.0f} % of max; "
            f"{figures['realtime_factor']:.1f}x real time "
            f"({figures['cpu_realtime_factor']:.1f}x per CPU second)",
            f"world: {figures['world']}; silent localisation failures (ok but > 0.3 m or "
            f"10 deg off): {figures['loc_silent_failures']} of the 10 Hz samples",
            *_error_lines(figures),
        ]
    )
    return ScenarioResult("tour", table, figures)


def _error_lines(figures: dict[str, Any]) -> list[str]:
    """The world-frame error split into the map's own and the localiser's (`map_echo`), and
    the covariance's honesty (NEES per degree of freedom: 1 when honest)."""
    lines = []
    if "loc_echo_rms_m" in figures:
        f = figures
        lines.append(
            f"the map pose's error split on {figures['loc_echo_samples']} samples: world frame RMS "
            f"{f['loc_sub_rms_m'] * 100:.1f} cm = map's own (a perfect matcher on this map) RMS "
            f"{f['loc_echo_rms_m'] * 100:.1f} / max {f['loc_echo_max_m'] * 100:.1f} cm + "
            f"localiser's own RMS {f['loc_own_rms_m'] * 100:.1f} / max "
            f"{f['loc_own_max_m'] * 100:.1f} cm"
        )
    if "loc_nees_per_dof" in figures:
        lines.append(
            f"covariance: NEES per dof {figures['loc_nees_per_dof']} (x, y, yaw), "
            f"{figures['loc_nees_position_per_dof']} (x, y); 1 when honest; "
            f"{figures['loc_inside_95'] * 100:.0f} % inside the 95 % region"
        )
    return lines
