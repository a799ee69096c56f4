"""Issue 11: no planner parameter can take the robot down; each refusal names field, value, range."""

from __future__ import annotations

import dataclasses

import pytest

from robot_daemon.planning.config import _RANGES, PlannerConfig, PlannerConfigError

HOSTILE = [
    ({"local_grid_resolution": 1e-6}, r"local_grid_resolution = 1e-06 is outside \[0.02, 0.2\]"),
    ({"sim_dt": 1e-4}, r"sim_dt = 0.0001 is outside \[0.02, 0.5\]"),
    ({"v_samples": 101}, r"v_samples = 101 is outside \[2, 41\]"),
    ({"v_samples": 41, "w_samples": 61, "sim_time": 5.0}, "rollout steps per cycle"),
    ({"max_linear_speed": 4.9}, r"max_linear_speed = 4.9 is outside \[0.05, 1.0\]"),
    ({"planning_resolution": 1e-5}, "planning_resolution"),
    ({"progress_timeout": 1e9}, "progress_timeout"),
    ({"max_linear_speed": float("nan")}, "max_linear_speed"),
    ({"v_samples": 2.5}, "v_samples"),
]


@pytest.mark.parametrize(("changes", "message"), HOSTILE)
def test_hostile_values_are_refused_with_a_reason(changes: dict, message: str) -> None:
    with pytest.raises(PlannerConfigError, match=message):
        PlannerConfig().replace(**changes)


def test_every_field_is_bounded_on_both_sides() -> None:
    numeric = {f.name for f in dataclasses.fields(PlannerConfig) if f.type in ("float", "int")}
    assert numeric <= set(_RANGES)
    for name, (low, high, _) in _RANGES.items():
        assert low < high and high < 1e5, name
