"""A match that jumped to a look-alike of the prediction gives no information along the corridor
(`Localiser._lookalike_of_prediction`, issue 12).

A corridor whose only feature along it is one shallow door recess: the slide test leaves the
match a few percent of its information along the corridor (a handful of end points on the
recess's edges). A match 15 cm along the corridor from a prediction that is sure to 5 cm (3
sigma), where the scan fits the predicted pose as well, is another optimum, not a measurement:
with the rule on it carries nothing along the corridor; a prediction within 2 sigma of the match
keeps what the slide test allows, and so does every prediction with the rule off.
"""

from __future__ import annotations

import numpy as np
import pytest

from interbot_core.geometry import Pose2D
from robot_daemon.localisation import Localiser, LocaliserConfig
from robot_daemon.localisation.localiser import LocaliserConfigError
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


def _along(config: LocaliserConfig, offset: float, prior: np.ndarray = PRIOR) -> float:
    """Information along the corridor (x) of the scan at TRUTH matched from TRUTH, after the
    slide test, with the prediction ``offset`` [m] behind the match along the corridor."""
    loc = Localiser(rasterise(WALLS, (LENGTH, 1.5)), config)
    points = loc._scan_points(utm_scan(WALLS, TRUTH, 0.0, np.random.default_rng(3)))
    result: MatchResult = loc.matcher.match(points, TRUTH)
    predicted = Pose2D(result.pose.x - offset, result.pose.y, result.pose.yaw)
    info, _ = loc._slide_test(points, result, prior, predicted)
    return float(info[0, 0])


ON = LocaliserConfig(map_update=False, lookalike_sigma=2.0)
OFF = LocaliserConfig(map_update=False, lookalike_sigma=0.0)


def test_the_slide_test_leaves_a_little_information_along_the_corridor() -> None:
    """The scene does what the module says: capped, but not to nothing, with the rule off."""
    for offset in (0.0, 0.15):
        assert 5.0 < _along(OFF, offset) < 100.0  # the full point-to-surface value is ~970


def test_a_match_3_sigma_from_a_prediction_that_fits_as_well_carries_nothing_along() -> None:
    assert _along(ON, 0.15) < 0.1


def test_a_match_within_2_sigma_of_the_prediction_keeps_its_information() -> None:
    assert _along(ON, 0.0) == pytest.approx(_along(OFF, 0.0))
    assert _along(ON, 0.05) == pytest.approx(_along(OFF, 0.05))
    wide = np.diag([0.1**2, 0.02**2, 0.003**2])  # 0.15 m is 1.5 sigma of this prior
    assert _along(ON, 0.15, wide) == pytest.approx(_along(OFF, 0.15, wide))


def test_a_prediction_that_fits_clearly_worse_is_corrected_as_before() -> None:
    """``lookalike_drop`` 0: only a prediction fitting at least as well as the match counts as
    a look-alike; here the match fits a little better (it is the optimum), so the rule holds
    back and the slide test's value stays."""
    strict = LocaliserConfig(map_update=False, lookalike_sigma=2.0, lookalike_drop=0.0)
    assert _along(strict, 0.15) == pytest.approx(_along(OFF, 0.15))


@pytest.mark.parametrize(
    ("name", "value"),
    [("lookalike_sigma", -1.0), ("lookalike_drop", 1.5), ("lookalike_drop", float("nan"))],
)
def test_bad_lookalike_parameters_are_refused_by_name(name: str, value: float) -> None:
    with pytest.raises(LocaliserConfigError, match=name):
        LocaliserConfig(**{name: value})  # type: ignore[arg-type]
