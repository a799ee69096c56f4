"""The hardware: section of robot.yaml, and the example for the real robot (deploy/robot.yaml)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from robot_daemon.config import load_config
from robot_daemon.hardware.config import HardwareConfig, HardwareConfigError

DEPLOY = Path(__file__).resolve().parents[3] / "deploy" / "robot.yaml"


def test_defaults_are_valid() -> None:
    config = HardwareConfig.from_mapping({})
    assert config.motors.command == "G"
    assert config.motors.right_channel == 2
    assert config.motors.metres_per_count_lr[0] > 0


def test_deploy_example_parses() -> None:
    daemon = load_config(DEPLOY)
    assert daemon.backend == "hardware"
    hw = HardwareConfig.from_mapping(daemon.hardware, str(DEPLOY))
    assert hw.laser.port == "/dev/ttyACM0"
    assert hw.motors.port == "/dev/ttyUSB0"
    assert hw.motors.watchdog_ms == 500
    assert (hw.camera.width, hw.camera.height) == (320, 240)


@pytest.mark.parametrize(
    ("raw", "message"),
    [
        ({"motors": {"track": -1}}, r"hardware\.motors\.track = -1 is outside"),
        ({"motors": {"command": "P"}}, r"hardware\.motors\.command must be one of G, S; got 'P'"),
        ({"motors": {"watchdog_ms": 10.5}}, r"hardware\.motors\.watchdog_ms must be an integer"),
        ({"motors": {"left_sign": 2}}, r"hardware\.motors\.left_sign must be one of 1, -1; got 2"),
        ({"motors": {"wheel_radius": "big"}}, r"hardware\.motors\.wheel_radius must be a number"),
        ({"laser": {"port": ""}}, r"hardware\.laser\.port must be a device path"),
        (
            {"laser": {"speed": 3}},
            r"unknown key 'hardware\.laser\.speed' \(allowed: port, baudrate",
        ),
        ({"camera": {"device": True}}, r"hardware\.camera\.device must be an index or a path"),
        ({"camera": {"jpeg_quality": 0}}, r"hardware\.camera\.jpeg_quality = 0 is outside"),
        (
            {"lidar": {}},
            r"unknown key 'hardware\.lidar' \(allowed: laser, motors, camera, battery\)",
        ),
        ({"motors": []}, r"hardware\.motors must be an object with keys port, "),
        ({"motors": {"wheel_radius_left": 5}}, r"hardware\.motors\.wheel_radius_left = 5 is"),
        ({"motors": {"wheel_radius_right": "x"}}, r"hardware\.motors\.wheel_radius_right must"),
    ],
)
def test_errors_name_the_key(raw: dict[str, Any], message: str) -> None:
    with pytest.raises(HardwareConfigError, match=message) as info:
        HardwareConfig.from_mapping(raw, "robot.yaml")
    assert str(info.value).startswith("robot.yaml: ")


def test_per_wheel_radii_reach_the_drive_geometry() -> None:
    config = HardwareConfig.from_mapping(
        {"motors": {"wheel_radius": 0.1, "wheel_radius_left": 0.0995, "wheel_radius_right": 0.1012}}
    )
    assert config.motors.radii == (0.0995, 0.1012)
    assert HardwareConfig.from_mapping({}).motors.radii == (0.1, 0.1)
