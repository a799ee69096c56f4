"""The reckless-driver scenario: the run plan covers doors, corners, walls and people; through
the narrowest door the assisted robot gets in without touching the frame, while the monitor
alone keeps the unassisted robot off the frame but stuck in front of it."""

from __future__ import annotations

import dataclasses

import pytest

from robot_daemon.scenarios import teleop
from robot_daemon.scenarios.runner import ScenarioOptions

OPTIONS = ScenarioOptions(people=0)


@pytest.fixture(scope="module")
def systems() -> dict[str, teleop.SimulatedSystem]:
    return {s: teleop.make_system(OPTIONS, s) for s in ("assisted", "unassisted")}


def test_run_plan_covers_every_kind(systems: dict[str, teleop.SimulatedSystem]) -> None:
    runs = teleop.plan_runs(systems["assisted"], seed=1)
    kinds = {r.kind for r in runs}
    assert kinds == {"door", "corner", "wall", "person"}
    doors = [r for r in runs if r.kind == "door"]
    assert min(r.door_width for r in doors) == pytest.approx(0.9, abs=0.06)
    assert runs == teleop.plan_runs(systems["unassisted"], seed=1)  # deterministic


def test_assisted_driver_gets_through_the_narrow_door_the_monitor_alone_blocks(
    systems: dict[str, teleop.SimulatedSystem],
) -> None:
    runs = teleop.plan_runs(systems["assisted"], seed=1)
    door = min((r for r in runs if r.kind == "door"), key=lambda r: (r.door_width, r.label))
    door = dataclasses.replace(door, time_limit=12.0)  # through in ~5 s when it gets through
    assisted = teleop.drive(systems["assisted"], door)
    alone = teleop.drive(systems["unassisted"], door)
    assert assisted.collisions == 0 and alone.collisions == 0
    assert assisted.min_clearance > 0.01 and alone.min_clearance > 0.01
    assert assisted.through_s is not None and assisted.through_s < 10.0
    assert alone.through_s is None  # stopped at the frame, never through
    assert assisted.progress > 2.0 > alone.progress


def test_figures_and_table() -> None:
    result = teleop.run(OPTIONS, setups=("assisted",), limit=1)
    f = result.figures
    assert f["runs"] == 1 and f["collisions"] == 0
    for key in ("min_clearance_m", "progress_m", "time_to_doorway_s", "collisions_unassisted"):
        assert key in f
    assert "assisted" in result.table and "door passes" in result.table
