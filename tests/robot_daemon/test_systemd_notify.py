"""The notification protocol, with a datagram socket standing in for systemd."""

from __future__ import annotations

import socket
from collections.abc import Iterator
from pathlib import Path

import pytest

from robot_daemon.systemd_notify import SystemdNotifier


@pytest.fixture
def fake_systemd(tmp_path: Path) -> Iterator[tuple[socket.socket, str]]:
    path = str(tmp_path / "notify.sock")
    server = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    server.bind(path)
    server.settimeout(2.0)
    yield server, path
    server.close()


def test_ready_watchdog_stopping_arrive(fake_systemd: tuple[socket.socket, str]) -> None:
    server, path = fake_systemd
    notifier = SystemdNotifier({"NOTIFY_SOCKET": path, "WATCHDOG_USEC": "2000000"})
    assert notifier.enabled and notifier.watchdog_period == pytest.approx(1.0)
    assert notifier.ready("serving")
    assert server.recv(256) == b"READY=1\nSTATUS=serving"
    assert notifier.watchdog(now=10.0)
    assert not notifier.watchdog(now=10.5)  # within half the period: rate-limited
    assert notifier.watchdog(now=11.0)
    assert server.recv(256) == b"WATCHDOG=1"
    assert server.recv(256) == b"WATCHDOG=1"
    assert notifier.stopping()
    assert server.recv(256) == b"STOPPING=1"
    notifier.close()


def test_abstract_namespace_address() -> None:
    server = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    name = f"interbot-test-{id(server)}"
    server.bind(b"\0" + name.encode())
    server.settimeout(2.0)
    try:
        notifier = SystemdNotifier({"NOTIFY_SOCKET": "@" + name})
        assert notifier.ready()
        assert server.recv(64) == b"READY=1"
        notifier.close()
    finally:
        server.close()


def test_without_systemd_everything_is_a_noop() -> None:
    notifier = SystemdNotifier({})
    assert not notifier.enabled
    assert not notifier.ready() and not notifier.watchdog(0.0) and not notifier.stopping()


def test_bad_environment_is_ignored_with_a_warning(caplog: pytest.LogCaptureFixture) -> None:
    notifier = SystemdNotifier({"NOTIFY_SOCKET": "relative/path", "WATCHDOG_USEC": "soon"})
    assert not notifier.enabled and notifier.watchdog_period is None
    assert "NOTIFY_SOCKET" in caplog.text and "WATCHDOG_USEC" in caplog.text


def test_missing_socket_file_does_not_raise(tmp_path: Path) -> None:
    notifier = SystemdNotifier({"NOTIFY_SOCKET": str(tmp_path / "gone.sock")})
    assert notifier.ready() is False
    notifier.close()
