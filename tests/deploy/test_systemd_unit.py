"""deploy/interbot-daemon.service, and the daemon's side of the notify protocol it relies on.

The unit is parsed like systemd reads it (sections, ``Key=value``, repeated keys allowed) and,
where ``systemd-analyze`` exists, verified by it. The real ``interbot-daemon --sim`` process is
then run with ``NOTIFY_SOCKET`` pointing at a datagram socket this test binds (standing in for
systemd) and must send READY=1, WATCHDOG=1 at half of WATCHDOG_USEC, and STOPPING=1 on SIGTERM.
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
UNIT = REPO / "deploy" / "interbot-daemon.service"
pytestmark = pytest.mark.timeout(60)


def parse_unit(text: str) -> dict[str, dict[str, list[str]]]:
    """systemd's unit syntax: [Section], Key=value, '#'/';' comments, repeatable keys."""
    sections: dict[str, dict[str, list[str]]] = {}
    current: dict[str, list[str]] | None = None
    for number, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        if not line or line.startswith(("#", ";")):
            continue
        if line.startswith("[") and line.endswith("]"):
            current = sections.setdefault(line[1:-1], {})
            continue
        assert current is not None, f"line {number}: key outside a section: {raw!r}"
        assert "=" in line, f"line {number}: not Key=value: {raw!r}"
        name, value = line.split("=", 1)
        current.setdefault(name.strip(), []).append(value.strip())
    return sections


@pytest.fixture(scope="module")
def unit() -> dict[str, dict[str, list[str]]]:
    return parse_unit(UNIT.read_text(encoding="utf-8"))


def test_parse_unit_rejects_keys_outside_sections() -> None:
    with pytest.raises(AssertionError, match="outside a section"):
        parse_unit("Type=notify\n")


def test_unit_runs_the_daemon_as_a_notify_service(unit: dict[str, dict[str, list[str]]]) -> None:
    assert set(unit) == {"Unit", "Service", "Install"}
    service = unit["Service"]

    def one(key: str) -> str:
        values = service.get(key, [])
        assert len(values) == 1, f"[Service] {key}= must be set exactly once, got {values}"
        return values[0]

    assert one("Type") == "notify"
    exec_start = one("ExecStart").split()
    assert Path(exec_start[0]).name == "interbot-daemon" and exec_start[0].startswith("/")
    assert exec_start[1:] == ["--config", "/etc/interbot/robot.yaml"]
    watchdog = one("WatchdogSec")
    assert watchdog.endswith("s") and 1 <= float(watchdog[:-1]) <= 30
    assert one("Restart") == "on-failure"
    assert one("RestartPreventExitStatus") == "2"  # the daemon's exit status for a bad config
    assert one("User") == "interbot"
    assert "dialout" in one("SupplementaryGroups").split()
    assert one("StandardOutput") == "journal"
    assert "PYTHONUNBUFFERED=1" in " ".join(service["Environment"]).split()
    assert one("NoNewPrivileges") == "yes"
    assert one("ProtectSystem") == "strict"
    assert one("ProtectHome") == "yes"
    writable = one("ReadWritePaths").split()
    assert writable and all(p.startswith("/var/") for p in writable)
    # The compiled kernels' cache (robot_daemon/jit.py: $CACHE_DIRECTORY), /opt being read-only.
    assert one("CacheDirectory") == "interbot"
    # Issue 14: the command threads may use SCHED_FIFO at COMMAND_PRIORITY, and no higher.
    from interbot_link.command_priority import COMMAND_PRIORITY

    assert one("RestrictRealtime") == "no"
    assert int(one("LimitRTPRIO")) == COMMAND_PRIORITY
    # Serial ports and the camera are devices: the unit must not hide /dev.
    assert service.get("PrivateDevices", ["no"]) == ["no"]
    assert unit["Install"]["WantedBy"] == ["multi-user.target"]


def test_systemd_analyze_verify_accepts_the_unit(tmp_path: Path) -> None:
    analyze = shutil.which("systemd-analyze")
    if analyze is None:
        pytest.skip("systemd-analyze not installed (apt-get install systemd)")
    daemon = shutil.which("interbot-daemon") or str(Path(sys.executable).parent / "interbot-daemon")
    if not Path(daemon).exists():
        pytest.skip("interbot-daemon entry point not installed (pip install -e .)")
    # verify also checks that ExecStart exists: point it at this checkout's entry point.
    text = UNIT.read_text(encoding="utf-8").replace(
        "/opt/interbot/venv/bin/interbot-daemon", daemon
    )
    copy = tmp_path / "interbot-daemon.service"
    copy.write_text(text, encoding="utf-8")
    result = subprocess.run(
        [analyze, "verify", str(copy)], capture_output=True, text=True, timeout=30, check=False
    )
    problems = [
        line
        for line in (result.stdout + result.stderr).splitlines()
        if "interbot-daemon.service" in line or "Unknown" in line
    ]
    assert result.returncode == 0 and not problems, result.stdout + result.stderr


@pytest.fixture
def fake_systemd() -> Iterator[tuple[socket.socket, str]]:
    # A short directory: AF_UNIX paths are limited to 108 bytes and tmp_path can be longer.
    directory = tempfile.mkdtemp(prefix="ibnotify")
    path = os.path.join(directory, "notify.sock")
    server = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    server.bind(path)
    try:
        yield server, path
    finally:
        server.close()
        shutil.rmtree(directory, ignore_errors=True)


def _receive(server: socket.socket, timeout: float) -> tuple[float, str]:
    server.settimeout(timeout)
    data = server.recv(4096)
    return time.monotonic(), data.decode()


def test_daemon_process_notifies_ready_watchdog_and_stopping(
    fake_systemd: tuple[socket.socket, str], free_tcp_port: Callable[[], int]
) -> None:
    server, path = fake_systemd
    endpoint = f"tcp/127.0.0.1:{free_tcp_port()}"
    cmd = [sys.executable, "-m", "robot_daemon.main", "--sim", "--robot-id", "notify1"]
    cmd += ["--listen", endpoint, "--people", "0"]
    env = {
        **os.environ,
        "PYTHONUNBUFFERED": "1",
        "NOTIFY_SOCKET": path,
        "WATCHDOG_USEC": "2000000",
    }
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=env)
    try:
        _, first = _receive(server, 30.0)
        assert first.split("\n")[0] == "READY=1", first
        assert "STATUS=robot notify1 serving" in first
        t1, ping1 = _receive(server, 5.0)
        assert ping1 == "WATCHDOG=1"
        t2, ping2 = _receive(server, 5.0)
        assert ping2 == "WATCHDOG=1"
        # Half of WATCHDOG_USEC (1 s) between pings, from the 50 Hz loop: not faster, not late.
        assert 0.9 <= t2 - t1 <= 1.6, t2 - t1
        proc.send_signal(signal.SIGTERM)
        messages = []
        while not messages or messages[-1] != "STOPPING=1":
            messages.append(_receive(server, 15.0)[1])
        assert set(messages[:-1]) <= {"WATCHDOG=1"}, messages
        assert proc.wait(15.0) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        if proc.stdout:
            proc.stdout.close()
