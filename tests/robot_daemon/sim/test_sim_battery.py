"""BMS model: 8-cell Li-ion pack voltages, drain and cut-off."""

from __future__ import annotations

import pytest

from robot_daemon.sim.battery import (
    Battery,
    BatteryConfig,
    BatteryConfigError,
    open_circuit_cell_voltage,
)


def test_pack_voltages() -> None:
    cfg = BatteryConfig()
    assert cfg.cutoff_voltage == pytest.approx(24.0)
    assert open_circuit_cell_voltage(1.0) == pytest.approx(4.2)
    assert open_circuit_cell_voltage(0.0) == pytest.approx(3.0)
    state = Battery(BatteryConfig(internal_resistance=0.0)).state()
    assert state.voltage == pytest.approx(33.6) and state.soc == 1.0 and not state.cutoff


def test_motion_drains_faster_than_idle() -> None:
    idle, moving = Battery(), Battery()
    for k in range(600):
        idle.step(1.0, 0.0, 0.0, float(k))
        moving.step(1.0, 0.6, 0.5, float(k))
    assert moving.state().soc < idle.state().soc < 1.0
    assert moving.state().current > idle.state().current > 0
    # Idle 20 W for 10 min from a 20 Ah pack at ~33 V: about 0.5 % of charge.
    assert 1.0 - idle.state().soc == pytest.approx(20 * 600 / 3600 / 33.3 / 20, rel=0.05)
    assert moving.state().voltage < idle.state().voltage


def test_bms_cuts_off_at_three_volts_per_cell() -> None:
    battery = Battery(BatteryConfig(capacity_ah=0.05, initial_soc=0.2))
    t = 0.0
    while not battery.cutoff and t < 3600:
        battery.step(1.0, 0.8, 0.0, t)
        t += 1.0
    state = battery.state()
    assert state.cutoff and state.current == 0.0
    assert state.cell_voltage <= 3.06
    battery.step(1.0, 0.8, 0.0, t)
    assert battery.cutoff and battery.state().current == 0.0  # latched


def test_deterministic_and_validated() -> None:
    a, b = Battery(), Battery()
    for k in range(50):
        a.step(0.1, 0.3, 0.1, k * 0.1)
        b.step(0.1, 0.3, 0.1, k * 0.1)
    assert a.state() == b.state()
    with pytest.raises(BatteryConfigError, match="initial_soc"):
        BatteryConfig(initial_soc=1.5)
