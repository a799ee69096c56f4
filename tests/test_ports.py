"""tests/ports.py: a port reserved for a server started later is held, and that server gets it.

The rig's daemons listen on such ports seconds after they were chosen; a port merely closed again
was free for anyone's ``bind(0)`` meanwhile (the cause of a test_fault_station timeout).
"""

from __future__ import annotations

import errno
import socket

import pytest
import zenoh

from interbot_link import session_config
from tests.ports import HOST, reserve_port


def test_a_reserved_port_is_held_against_binds_without_reuse() -> None:
    port = reserve_port()
    with socket.socket() as other, pytest.raises(OSError) as raised:
        other.bind((HOST, port))
    assert raised.value.errno == errno.EADDRINUSE


def test_the_daemons_zenoh_listener_binds_a_reserved_port() -> None:
    port = reserve_port()
    with (
        zenoh.open(session_config([f"tcp/{HOST}:{port}"], [])),
        socket.create_connection((HOST, port), timeout=5.0),
    ):
        pass  # the session listens on it


def test_a_port_is_reserved_again_for_a_restart_unless_someone_listens() -> None:
    port = reserve_port()
    assert reserve_port(port) == port  # a killed daemon's port, held again before its restart
    with socket.socket() as listener:
        listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        listener.bind((HOST, port))
        listener.listen(1)
        with pytest.raises(OSError):
            reserve_port(port)  # taken: said at once, not as a robot that never comes
