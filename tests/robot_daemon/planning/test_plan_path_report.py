from __future__ import annotations

import itertools
import math

import pytest

from interbot_core.topics import PlanMsg, Topic, TopicDecodeError, decode, encode
from robot_daemon.planning.path_report import plan_message, thin_path


def test_thinning_keeps_the_ends_and_a_spacing() -> None:
    path = [(0.05 * i, 0.0) for i in range(101)]  # 5 m at one grid cell
    thin = thin_path(path, spacing=0.2)
    assert thin[0] == (0.0, 0.0) and thin[-1] == pytest.approx((5.0, 0.0))
    gaps = [math.dist(a, b) for a, b in itertools.pairwise(thin)]
    assert all(g >= 0.2 - 1e-9 for g in gaps[:-1])
    assert 21 <= len(thin) <= 26  # 5 m at >= 0.2 m (float steps may skip to 0.25 m)


def test_long_paths_fit_the_message_limit() -> None:
    path = [(0.01 * i, 0.0) for i in range(100_000)]
    assert len(thin_path(path, 0.01, max_points=100)) <= 100


def test_plan_message_round_trips_and_refuses_nonsense() -> None:
    msg = plan_message(7, [(0.0, 0.0), (1.0, 1.0)], stamp=3.0)
    assert decode(Topic.PLAN, encode(Topic.PLAN, msg)) == msg
    assert decode(Topic.PLAN, b'{"route_id":0,"points":[]}') == PlanMsg(0, ())
    for bad in (
        b'{"route_id":1,"points":[[0,0,0]]}',
        b'{"route_id":1,"points":[[0,"a"]]}',
        b'{"route_id":-1,"points":[]}',
        b'{"route_id":1,"points":[[1e9,0]]}',
    ):
        with pytest.raises(TopicDecodeError):
            decode(Topic.PLAN, bad)
