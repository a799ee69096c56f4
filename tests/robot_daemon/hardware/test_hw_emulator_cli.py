"""The emulators as processes: ``python -m ... --pty`` prints a port the daemon can open."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
import serial


@pytest.mark.parametrize(
    ("module", "request_bytes", "reply_prefix"),
    [
        (
            "tests.robot_daemon.hardware.emulators.hokuyo_emulator",
            b"PP\n",
            b"PP\n00P\nMODL:UTM-30LX-EW;I\n",
        ),
        (
            "tests.robot_daemon.hardware.emulators.roboteq_emulator",
            b"^ECHOF 1\r?V\r",
            b"^ECHOF 1\r+\rV=120:296:5000\r",
        ),
    ],
)
def test_emulator_process_serves_a_pty(
    tmp_path: Path, module: str, request_bytes: bytes, reply_prefix: bytes
) -> None:
    link = tmp_path / "tty"
    with subprocess.Popen(
        [sys.executable, "-m", module, "--pty", "--link", str(link)],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
    ) as proc:
        try:
            assert proc.stdout is not None
            assert proc.stdout.readline().decode().strip() == str(link)
            with serial.Serial(str(link), 115200, timeout=1.0) as port:
                port.write(request_bytes)
                assert port.read(len(reply_prefix)) == reply_prefix
        finally:
            proc.terminate()
            assert proc.wait(timeout=5) == 0
    assert not link.exists()  # the link is removed on SIGTERM
