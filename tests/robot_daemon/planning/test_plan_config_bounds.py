"""Issue 11: no planner parameter can take the robot down; each refusal names field, value, range."""

from __future__ import annotations

import msgspec
import pytest

from robot_daemon.planning.config import PlannerConfig, PlannerConfigError

HOSTILE = [
    (
        {"local_grid_resolution": 1e-6},
        r"local_grid_resolution = 1e-06 m is outside the allowed range \[0.02, 0.2\] m",
    ),
    ({"sim_dt": 1e-4}, r"sim_dt = 0.0001 s is outside the allowed range \[0.02, 0.5\] s"),
    ({"v_samples": 101}, r"v_samples = 101 is outside the allowed range 2\.\.41"),
    ({"v_samples": 41, "w_samples": 61, "sim_time": 5.0}, "rollout steps per cycle"),
    (
        {"max_linear_speed": 4.9},
        r"max_linear_speed = 4.9 m/s is outside the allowed range \[0.05, 1\] m/s",
    ),
    ({"planning_resolution": 1e-5}, "planning_resolution"),
    ({"progress_timeout": 1e9}, "progress_timeout"),
    ({"max_linear_speed": float("nan")}, r"max_linear_speed must be a finite number \[m/s\]"),
    ({"v_samples": 2.5}, r"v_samples must be an integer in 2..41, got 2.5"),
    ({"allow_unknown": "yes"}, "allow_unknown must be true or false"),
]


@pytest.mark.parametrize(("changes", "message"), HOSTILE)
def test_hostile_values_are_refused_with_a_reason(changes: dict, message: str) -> None:
    with pytest.raises(PlannerConfigError, match=message):
        PlannerConfig().replace(**changes)


def test_every_field_is_bounded_on_both_sides() -> None:
    info = msgspec.inspect.type_info(PlannerConfig)
    assert isinstance(info, msgspec.inspect.StructType)
    numeric = 0
    for field in info.fields:
        kind = field.type.type if isinstance(field.type, msgspec.inspect.Metadata) else field.type
        if isinstance(kind, msgspec.inspect.IntType | msgspec.inspect.FloatType):
            numeric += 1
            assert kind.ge is not None and kind.le is not None, field.name
            assert kind.ge < kind.le < 1e5, field.name
        else:
            assert isinstance(kind, msgspec.inspect.BoolType), field.name
    assert numeric >= 38
