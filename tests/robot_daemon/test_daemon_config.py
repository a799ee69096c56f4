from __future__ import annotations

from pathlib import Path

import pytest

from robot_daemon.config import ConfigError, DaemonConfig, load_config, parse_config


def test_defaults_are_valid_and_point_at_the_isr_floor() -> None:
    cfg = DaemonConfig()
    assert cfg.backend == "sim" and cfg.robot_id == "interbot1"
    assert cfg.map_yaml.name == "isr_floor0.yaml"
    assert cfg.zenoh.listen == ("tcp/127.0.0.1:7447",)


def test_full_file_parses_with_relative_paths(tmp_path: Path) -> None:
    (tmp_path / "robot.yaml").write_text(
        "robot_id: bot-2\nmap: maps/m.yaml\nbackend: sim\n"
        "rates: {controller_hz: 20}\nsim: {seed: 7, people: 0, odometry: perfect}\n"
        "zenoh: {listen: ['tcp/127.0.0.1:9000'], connect: []}\n"
    )
    cfg = load_config(tmp_path / "robot.yaml")
    assert cfg.robot_id == "bot-2"
    assert cfg.map_yaml == (tmp_path / "maps" / "m.yaml").resolve()
    assert cfg.rates.controller_hz == 20.0 and cfg.rates.localiser_hz == 10.0
    assert cfg.sim.seed == 7 and cfg.sim.odometry == "perfect"
    assert cfg.zenoh.listen == ("tcp/127.0.0.1:9000",)


@pytest.mark.parametrize(
    ("raw", "message"),
    [
        ({"robot_id": "bad id!"}, "robot_id"),
        ({"backend": "ros"}, "backend"),
        ({"speed": 3}, "unknown key"),
        ({"rates": {"controller_hz": 0}}, "controller_hz"),
        ({"rates": {"warp_hz": 1}}, "unknown key"),
        ({"sim": {"people": -1}}, "people"),
        ({"sim": {"odometry": "great"}}, "odometry"),
        ({"zenoh": {"listen": ["udp/224.0.0.224:7446"]}}, "tcp/HOST:PORT"),
        ({"zenoh": {"listen": [], "connect": []}}, "at least one"),
        ({"map": 5}, "'map' must be a file path"),
        ([1, 2], "mapping"),
    ],
)
def test_bad_configuration_is_refused_with_a_clear_message(raw: object, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        parse_config(raw, "robot.yaml", Path("."))


def test_unreadable_and_invalid_yaml(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="cannot read"):
        load_config(tmp_path / "missing.yaml")
    (tmp_path / "bad.yaml").write_text("robot_id: [unclosed\n")
    with pytest.raises(ConfigError, match="invalid YAML"):
        load_config(tmp_path / "bad.yaml")


def test_map_surface_is_one_model_whatever_the_backend(tmp_path: Path) -> None:
    """The wall model is the map's, learnt from the scans the same way whatever the backend
    (``learn``, issue 12), or fixed by the user; never one chosen per backend."""
    assert DaemonConfig().localiser.map_surface == "learn"
    assert DaemonConfig(backend="hardware").localiser.map_surface == "learn"
    (tmp_path / "robot.yaml").write_text("localiser: {map_surface: cell_face}\n")
    cfg = load_config(tmp_path / "robot.yaml")
    assert cfg.localiser.map_surface == "cell_face"
    (tmp_path / "robot.yaml").write_text("localiser: {map_surface: cell_centre}\n")
    assert load_config(tmp_path / "robot.yaml").localiser.map_surface == "cell_centre"
    with pytest.raises(ConfigError, match="map_surface"):
        parse_config({"localiser": {"map_surface": "auto"}}, "robot.yaml", tmp_path)
    with pytest.raises(ConfigError, match="map_surface"):
        parse_config({"localiser": {"map_surface": "edge"}}, "robot.yaml", tmp_path)
    with pytest.raises(ConfigError, match="help_after_s"):
        parse_config({"localiser": {"help_after_s": -1}}, "robot.yaml", tmp_path)
    config = parse_config({"localiser": {"help_after_s": 45}}, "robot.yaml", tmp_path)
    assert config.localiser.help_after_s == 45


def test_look_around_is_on_by_default_and_robot_yaml_turns_it_off(tmp_path: Path) -> None:
    """Issue 16: turning in place while the global search is undecided, configurable."""
    from robot_daemon.config import SimSettings
    from robot_daemon.daemon import Daemon, DaemonOptions

    assert DaemonConfig().localiser.look_around is True
    config = parse_config({"localiser": {"look_around": False}}, "robot.yaml", tmp_path)
    assert config.localiser.look_around is False
    with pytest.raises(ConfigError, match="look_around"):
        parse_config({"localiser": {"look_around": "sometimes"}}, "robot.yaml", tmp_path)
    daemon = Daemon(config.with_overrides(sim=SimSettings(people=0)), DaemonOptions())
    assert daemon.stack.look_around.config.enabled is False
    on = Daemon(DaemonConfig(sim=SimSettings(people=0)), DaemonOptions(relocalise=False))
    assert on.stack.look_around.config.enabled is False  # --no-relocalise: no search, no turn


def test_the_daemon_says_a_new_contact_once_as_a_collision() -> None:
    """Device health reaches the station as status lines the alert rules recognise."""
    from unittest.mock import MagicMock

    from robot_daemon.backend import DeviceStatus
    from robot_daemon.config import DaemonConfig, SimSettings
    from robot_daemon.daemon import Daemon, DaemonOptions

    daemon = Daemon(DaemonConfig(sim=SimSettings(people=0)), DaemonOptions())
    contacts = [0]
    daemon.backend.device_status = lambda: [  # type: ignore[method-assign]
        DeviceStatus("motors", True, "sim", {"contacts": contacts[0]})
    ]
    link = MagicMock()
    texts: list[str] = []
    link.publish.side_effect = lambda topic, message: texts.append(getattr(message, "text", ""))
    for step in range(6):
        daemon.now = step * 1.0  # the status rate is 2 Hz: every call is due
        contacts[0] = 0 if step < 3 else 1
        daemon.publish(link)
    collisions = [t for t in texts if t.startswith("collision:")]
    assert len(collisions) == 1 and "1 new contact" in collisions[0]


def test_the_learnt_wall_model_is_a_standing_notice_for_stations_that_join_later() -> None:
    """The operator's line about the learnt wall model is published as a status line and kept
    in the robot's standing notices (in the snapshot a late station reads), once."""
    from unittest.mock import MagicMock

    from interbot_core.topics import StandingNotices, Status, Topic
    from robot_daemon.config import DaemonConfig, SimSettings
    from robot_daemon.daemon import Daemon, DaemonOptions
    from robot_daemon.localisation.wall_model import WallModelStatus

    daemon = Daemon(DaemonConfig(sim=SimSettings(people=0)), DaemonOptions())
    learnt = WallModelStatus("cell_centre", False, True, {"cell_centre": 9}, 12, 7.5)
    daemon.stack.localiser._wall_model.status = lambda: learnt  # type: ignore[method-assign]
    link = MagicMock()
    published: list[tuple[Topic, object]] = []
    link.publish.side_effect = lambda topic, message: published.append((topic, message))
    for step in range(3):
        daemon.now = float(step)
        daemon.stack._track_wall_model(daemon.now)
        daemon.publish(link)
    lines = [m for t, m in published if t is Topic.STATUS and isinstance(m, Status)]
    said = [m for m in lines if "walls lie through the cell centres" in m.text]
    notices = [m for t, m in published if t is Topic.NOTICES]
    assert len(said) == 1
    assert notices == [StandingNotices((said[0],))]
