from __future__ import annotations

import math

import pytest

from base_station_app.display_text import (
    UNSET,
    age_text,
    estop_text,
    localisation_text,
    orientation_text,
    position_text,
)
from interbot_core.topics import PoseMsg


def test_unset_pose_is_a_dash_not_zeros() -> None:
    unset = PoseMsg(0.0, 0.0, 0.0, state="unset", confidence=0.0)
    assert position_text(None) == position_text(unset) == UNSET
    assert orientation_text(unset) == UNSET
    assert position_text(PoseMsg(1.0, -2.5, 0.0)) == "x 1.00 m, y -2.50 m"
    assert orientation_text(PoseMsg(0.0, 0.0, math.pi / 2)).startswith("90.0°")


@pytest.mark.parametrize(
    ("seconds", "text"),
    [(0.25, "0.25 s"), (12.4, "12 s"), (203.995, "3 min 23 s"), (7500, "2 h 5 min")],
)
def test_ages_read_like_a_person_would_say_them(seconds: float, text: str) -> None:
    assert age_text(seconds) == text
    assert age_text(math.inf) == "never"


def test_estop_line_never_pairs_latched_with_clear_silently() -> None:
    assert estop_text(False, False) == ("released", False)
    assert estop_text(True, True)[1] is True
    text, alarm = estop_text(True, False)
    assert alarm and "not stopped yet" in text
    text, alarm = estop_text(False, True)
    assert alarm and "still stopped" in text
    assert "no answer" in estop_text(True, None)[0]


def test_localisation_line_names_every_state_and_shows_the_sigmas() -> None:
    cov = (0.0025, 0.0, 0.0, 0.0, 0.01, 0.0, 0.0, 0.0, math.radians(2.0) ** 2)
    pose = PoseMsg(1.0, 2.0, 0.0, state="degraded", confidence=0.8, covariance=cov)
    assert localisation_text("degraded", pose) == (
        "DEGRADED (uncertain: driving slowly) (confidence 0.80), ±10 cm, ±2.0°"
    )
    assert localisation_text("ok", PoseMsg(1.0, 2.0, 0.0)) == "localised (confidence 1.00)"
    for state in ("unset", "ok", "degraded", "lost", "searching", "turning"):
        assert localisation_text(state, None) != state  # every agreed state has words
    assert "turning to find my position" in localisation_text("turning", None)
