"""Kidnap scenario, cold starts (issue 16): switched on with the pose unset and given a task.

Seed 1's first two power-ons on the realistic ISR world: a room (decided standing within a
second) and a corridor spot whose standing scan fits several corridor places alike (idle, the
robot asks for help there: measured while writing this test). Given its route at power-on the
robot serves a command, turns in place, and finds itself; times are from power-on; never wrong.
"""

from __future__ import annotations

from robot_daemon.scenarios.kidnap import run_cold_starts, topo_for
from robot_daemon.scenarios.runner import ScenarioOptions


def test_a_robot_given_its_task_at_power_on_turns_and_finds_itself() -> None:
    options = ScenarioOptions(seed=1, cold_start=True)
    tally = run_cold_starts(options, topo_for(options.map_yaml, options.topo_yaml), count=2)
    f = tally.figures()
    assert f["kidnaps"] == 2 and f["wrong_relocalisations"] == 0
    assert f["relocalised"] == 2, tally.records
    room, corridor = tally.records
    assert room.relocalise_s is not None and 0.5 <= room.relocalise_s <= 2.0
    assert corridor.relocalise_s is not None and corridor.relocalise_s > room.relocalise_s


def test_a_robot_kidnapped_at_a_tour_stop_looks_around_once_the_next_leg_comes() -> None:
    """ISR seed 5's first kidnap: standing at a tour stop, carried to a corridor spot whose
    standing scan fits look-alike places (measured while writing this test). Idle, it may not
    turn (no motion nobody commanded): it searches standing still and asks for help. When the
    visitor taps Resume after the dwell, the next leg is a command it serves: it turns and
    finds itself, after the leg came, never wrong."""
    from dataclasses import replace

    from robot_daemon.scenarios.kidnap import TOUR_DWELL_S, run_kidnaps

    options = ScenarioOptions(seed=5)
    topo = topo_for(options.map_yaml, options.topo_yaml)
    idle = run_kidnaps(options, topo, count=1).records[0]
    assert idle.standing and idle.relocalise_s is None and not idle.wrong
    assert idle.help == 1
    tour = run_kidnaps(replace(options, tour_resumes=True), topo, count=1).records[0]
    assert tour.standing and not tour.wrong
    assert tour.relocalise_s is not None, tour
    assert TOUR_DWELL_S - 1.0 - 0.5 < tour.relocalise_s <= 10.0  # the leg came 3.5-4 s after
