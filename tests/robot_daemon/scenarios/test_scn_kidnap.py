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
