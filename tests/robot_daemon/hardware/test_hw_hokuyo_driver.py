"""The Hokuyo driver against the SCIP 2.0 emulator on a pseudo-terminal."""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest
import serial

from robot_daemon.hardware import scip
from robot_daemon.hardware.config import LaserConfig
from robot_daemon.hardware.hokuyo_driver import HokuyoDriver
from tests.robot_daemon.hardware.emulators.hokuyo_emulator import HokuyoEmulator

Until = Callable[..., bool]


def _driver(port: str) -> HokuyoDriver:
    # The product's stall timeout (0.5 s) and a long reply timeout: with 0.15 s and 0.3 s a
    # loaded machine that starved the emulator's or the driver's thread made stalls and
    # handshake failures the tests did not inject.
    return HokuyoDriver(
        LaserConfig(port=port, stall_timeout=0.5, reconnect_delay=0.05), reply_timeout=2.0
    )


@pytest.fixture
def driver(hokuyo: HokuyoEmulator) -> Iterator[HokuyoDriver]:
    drv = _driver(hokuyo.port).start()
    yield drv
    drv.close()


def test_emulator_answers_the_spec_handshake(hokuyo: HokuyoEmulator) -> None:
    """Raw pyserial exchange: echo, status and sums exactly as the spec prints them."""
    with serial.Serial(hokuyo.port, 115200, timeout=0.5) as port:

        def ask(command: bytes) -> bytes:
            port.write(command)
            reply = b""
            while not reply.endswith(b"\n\n"):
                chunk = port.read(1)
                assert chunk, f"no reply to {command!r}"
                reply += chunk
            return reply

        assert ask(b"SCIP2.0\n") == b"SCIP2.0\n0Ee\n\n"
        pp = ask(b"PP\n")
        assert b"\nAMAX:1080;Z\n" in pp and b"\nDMIN:23;7\n" in pp
        assert ask(b"BM\n") == b"BM\n00P\n\n"
        assert ask(b"BM\n") == b"BM\n02R\n\n"
        gd = ask(b"GD0000108000\n")
        assert len(gd) == 3369
        assert ask(b"QT\n") == b"QT\n00P\n\n"


def test_handshake_geometry_and_ranges(
    hokuyo: HokuyoEmulator, driver: HokuyoDriver, until: Until
) -> None:
    assert until(lambda: driver.latest()[0] >= 3)
    assert [c for c in hokuyo.commands[:7]] == [
        "QT",
        "SCIP2.0",
        "VV",
        "PP",
        "II",
        "BM",
        "MD0000108000000",
    ]
    params = driver.params
    assert params is not None and params.steps == 1081
    _, scan = driver.latest()
    assert scan is not None
    assert scan.ranges.size == 1081
    assert scan.angle_min == pytest.approx(-540 * 2 * math.pi / 1440)
    assert scan.angle_increment == pytest.approx(2 * math.pi / 1440)
    assert scan.angles[540] == pytest.approx(0.0)
    assert (scan.range_min, scan.range_max) == (0.023, 60.0)
    expected = hokuyo.ranges_for(0) / 1000.0
    np.testing.assert_allclose(scan.ranges, expected, rtol=0, atol=1e-6)
    status = driver.status()
    assert status.ok and status.counters["bad_sum"] == 0 and driver.version["PROT"] == "SCIP 2.0"


def test_scans_are_stamped_at_their_first_beam(
    hokuyo: HokuyoEmulator, driver: HokuyoDriver, until: Until
) -> None:
    """A scan's stamp is the time of its first beam, found from the least-delayed frame
    (`scip.ScanClock`): a stamp at the reception, or at the last beam, would be one scan
    duration (18.75 ms) or more late.

    The error of every stamp is the smallest transfer delay seen so far (never negative), so it
    can only shrink as frames come. A quiet machine gets a frame through within 4 ms at once; a
    loaded one delayed all of the first 20 by 25 ms, so the test waits (up to 10 s, less than
    the 400-scan window) for the first frame that came through that quickly. (Measured: a
    driver that stamps the last beam stays 19 ms off and fails.)"""
    errors: list[float] = []

    def converged() -> bool:
        seq, scan = driver.latest()
        if scan is None or seq < 20:
            return False
        # The emulator logs the true host time of each scan's first beam.
        closest = min((first for _, first, _ in hokuyo.sent), key=lambda t: abs(t - scan.stamp))
        errors.append(scan.stamp - closest)
        return abs(errors[-1]) < 0.004  # within the USB/pty transfer jitter

    assert until(converged), f"stamp errors [s]: {errors[:3]} ... {errors[-3:]}"


def test_error_codes_become_invalid_beams(tmp_path: Path, until: Until) -> None:
    profile = np.full(1081, 2000)
    profile[10] = 1  # SCIP error code (below DMIN)
    profile[20] = 65000  # beyond DMAX
    with HokuyoEmulator(ranges_mm=profile, link=tmp_path / "tty") as emu:
        drv = _driver(emu.port).start()
        try:
            assert until(lambda: drv.latest()[1] is not None)
            scan = drv.latest()[1]
            assert scan is not None
            assert np.isnan(scan.ranges[10]) and np.isinf(scan.ranges[20])
            assert not scan.valid()[10] and not scan.valid()[20] and scan.valid()[30]
        finally:
            drv.close()


def test_bad_sum_and_truncated_line_drop_the_scan(
    hokuyo: HokuyoEmulator, driver: HokuyoDriver, until: Until
) -> None:
    assert until(lambda: driver.latest()[0] >= 2)
    sent_before = hokuyo.scans_sent
    seq_before = driver.latest()[0]
    hokuyo.inject_bad_sum(2)
    hokuyo.inject_truncated(1)
    assert until(lambda: hokuyo.scans_sent >= sent_before + 8)
    assert until(lambda: driver.latest()[0] >= seq_before + 4)
    counters = driver.status().counters
    assert counters["bad_sum"] == 2
    assert counters["truncated"] == 1
    # Every sent scan is either delivered or counted as dropped, never both.
    delivered = driver.latest()[0] - seq_before
    assert delivered + 3 <= hokuyo.scans_sent - sent_before + 1
    _, scan = driver.latest()
    assert scan is not None and np.isfinite(scan.ranges).all()


def test_stall_is_detected_and_driver_reconnects(
    hokuyo: HokuyoEmulator, driver: HokuyoDriver, until: Until
) -> None:
    """The emulator stays silent until the test ends the stall, so the driver's "stalled"
    state is waited on while it lasts (with a 0.4 s stall, a loaded machine looked after it
    had reconnected); every reconnection attempt into the silence is a stall too."""
    assert until(lambda: driver.latest()[0] >= 2)
    hokuyo.stall(math.inf)
    assert until(lambda: driver.status().counters["stalls"] >= 1)
    status = driver.status()
    assert not status.ok and "stalled" in status.message
    seq = driver.latest()[0]
    hokuyo.stall(0.0)  # the firmware answers again
    assert until(lambda: driver.latest()[0] > seq + 2)
    status = driver.status()
    assert status.ok and status.counters["connects"] >= 2


def test_unplug_and_replug(hokuyo: HokuyoEmulator, driver: HokuyoDriver, until: Until) -> None:
    assert until(lambda: driver.latest()[0] >= 2)
    hokuyo.unplug(replug_after=None)  # replugged by the test: the state is seen while it lasts
    assert until(lambda: driver.status().counters["disconnects"] >= 1)
    assert "serial error" in driver.status().message
    seq = driver.latest()[0]
    hokuyo.replug()
    assert until(lambda: driver.latest()[0] > seq + 2)
    assert driver.status().ok


def test_wrapping_sensor_clock_keeps_stamps_increasing(tmp_path: Path, until: Until) -> None:
    with HokuyoEmulator(link=tmp_path / "tty", clock_start_ms=scip.TIMESTAMP_MODULUS - 100) as emu:
        drv = _driver(emu.port).start()
        stamps: list[float] = []
        seqs: list[int] = []
        try:
            last = 0

            def collect() -> bool:
                nonlocal last
                seq, scan = drv.latest()
                if scan is not None and seq != last:
                    last = seq
                    stamps.append(scan.stamp)
                    seqs.append(seq)
                return len(stamps) >= 12

            assert until(collect)
        finally:
            drv.close()
        assert any(ts < 100 for _, _, ts in emu.sent)  # the sensor clock did wrap
        assert np.all(np.diff(stamps) > 0.0)
        # No jump at the wrap: under 0.2 s per scan (25 ms), however many scans a loaded
        # machine let pass between two looks.
        assert np.all(np.diff(stamps) < 0.2 * np.diff(seqs))


def test_close_sends_qt_and_rs(hokuyo: HokuyoEmulator, until: Until) -> None:
    drv = _driver(hokuyo.port).start()
    assert until(lambda: drv.latest()[0] >= 1)
    drv.close()
    assert until(lambda: hokuyo.commands[-2:] == ["QT", "RS"])
    assert until(lambda: not hokuyo.streaming)
    assert drv.status().message == "closed"
    drv.close()  # idempotent


def test_missing_port_is_a_status_not_a_crash(tmp_path: Path, until: Until) -> None:
    drv = _driver(str(tmp_path / "nothing")).start()
    try:
        assert until(lambda: drv.status().counters["disconnects"] >= 2)
        status = drv.status()
        assert not status.ok and "serial error" in status.message
    finally:
        drv.close()


def test_garbage_before_replies_is_skipped(tmp_path: Path, until: Until) -> None:
    """A previous process left the sensor streaming: the QT at start-up drains it."""
    with HokuyoEmulator(link=tmp_path / "tty") as emu:
        fd = os.open(emu.pty.slave_path, os.O_RDWR | os.O_NOCTTY)
        os.write(fd, b"MD0000108000000\n")  # a crashed client's stream
        assert emu.wait_scans(2, 1.0)
        os.close(fd)
        drv = _driver(emu.port).start()
        try:
            assert until(lambda: drv.latest()[0] >= 3)
            assert drv.status().counters["handshake_failures"] == 0
        finally:
            drv.close()
