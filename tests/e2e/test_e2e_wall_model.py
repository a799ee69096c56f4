"""End to end, the wall model the robot learns reaches the operator (issue 12).

Where its map's walls lie in their cells is learnt by the robot from its own scans
(`robot_daemon.localisation.wall_model`); a model that moves every wall by half a cell is the
operator's to know. The daemon (simulated, 8x real time, the ISR map's own building: walls on
the cell faces) says it once as a status line; the Base Station, over zenoh on 127.0.0.1,
shows it in its log. The rig is tests/e2e/conftest.py's.
"""

from __future__ import annotations

from typing import Any

import pytest

from interbot_core.supervisor import GoTo

pytestmark = [pytest.mark.slow, pytest.mark.qt_log_ignore("This plugin does not support")]

ENTRANCE = 0  # Main Entrance (home)
SECRETARIAT = 2  # 9.5 m away: enough travel to learn the model (about 4 m)
NOTICE = "Localiser: this map's walls lie on the cell faces (learnt after"


def station_lines(rig: Any) -> list[str]:
    return [e.text for e in rig.station.selected.state.log if NOTICE in e.text]


def test_the_station_log_shows_the_wall_model_the_robot_learnt(make_rig: Any) -> None:
    rig = make_rig()
    rig.localise_at(ENTRANCE)
    assert rig.daemon.stack.localiser.wall_model.learning
    rig.station.submit(GoTo(SECRETARIAT))
    rig.wait(lambda: bool(station_lines(rig)), 40.0, "the learnt wall model at the station")
    status = rig.daemon.stack.localiser.wall_model
    assert status.decided and status.surface == "cell_face"
    assert station_lines(rig) == [f"robot: {status.notice()}"]  # once, as the robot said it
    assert f"(learnt after {status.decided_at_m:.1f} m)" in station_lines(rig)[0]
