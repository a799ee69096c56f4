"""The slide test caps a match's information along a corridor with one shallow feature
(`Localiser._slide_test`, issue 12).

A corridor whose only feature along it is one shallow door recess: the point-to-surface
information along the corridor is ~970 m⁻², but sliding the scan along it shows only a handful
of end points (the recess's edges) constrain it, so the slide test leaves a few percent: capped,
but not to nothing (the scan does say where the recess is).
"""

from __future__ import annotations

import numpy as np

from interbot_core.geometry import Pose2D
from robot_daemon.localisation import Localiser, LocaliserConfig
from robot_daemon.localisation.scan_matcher import MatchResult
from tests.robot_daemon.localisation.synthetic_office import rasterise, utm_scan

LENGTH = 30.0  # [m]
# Two walls 1.2 m apart and a door recess 0.9 m wide, 0.1 m deep in the north one at x = 16 m.
WALLS = np.array(
    [
        [0.0, 0.0, LENGTH, 0.1],
        [0.0, 1.3, 16.0, 1.4],
        [16.9, 1.3, LENGTH, 1.4],
        [16.0, 1.4, 16.9, 1.5],
    ]
)
TRUTH = Pose2D(15.0, 0.7, 0.0)
PRIOR = np.diag([0.05**2, 0.02**2, 0.003**2])  # 5 cm along the corridor


def test_the_slide_test_leaves_a_little_information_along_the_corridor() -> None:
    loc = Localiser(rasterise(WALLS, (LENGTH, 1.5)), LocaliserConfig(map_update=False))
    points = loc._scan_points(utm_scan(WALLS, TRUTH, 0.0, np.random.default_rng(3)))
    result: MatchResult = loc.matcher.match(points, TRUTH)
    full = float(loc.match_information(result)[0, 0])
    info, _ = loc._slide_test(points, result, PRIOR)
    assert full > 500.0  # what the point-to-surface information claims along the corridor
    assert 5.0 < float(info[0, 0]) < 100.0
