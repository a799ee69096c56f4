"""A loopback port for a server that another process will open seconds later.

Taking a port with ``bind(0)`` and closing the socket frees it at once: until the daemon (or
station) started as a subprocess binds it - 7-9 s on a loaded 2-core machine, while Python,
numpy and zenoh load - the kernel may hand the same port to anyone else's ``bind(0)`` (about
1 in 14,000 for each, measured), for example a station's tablet server in the same test. The
daemon then cannot listen ("Address already in use"), exits, and the test waits for a robot that
never comes (tests/faults/test_fault_station.py once timed out so, with the observer's zenoh
bytes arriving on the tablet port).

`reserve_port` keeps the port out of the kernel's choice instead: the server end of a
connection is closed first, so the port stays in TIME_WAIT (60 s on Linux). An automatic
``bind(0)`` skips a port in TIME_WAIT, while a server that sets ``SO_REUSEADDR`` - zenoh's TCP
listener and Qt's ``QTcpServer`` both do - binds it. The trick is Yelp's
``ephemeral-port-reserve``.
"""

from __future__ import annotations

import socket

HOST = "127.0.0.1"


def reserve_port(port: int = 0) -> int:
    """A loopback port (``port``, or one the OS picks when 0) held in TIME_WAIT for a server
    that sets ``SO_REUSEADDR``. Raises OSError when ``port`` is taken by a listener."""
    with socket.socket() as server:
        server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        server.bind((HOST, port))
        server.listen(1)
        address = server.getsockname()
        with socket.socket() as client:
            client.connect(address)
            accepted, _ = server.accept()
            accepted.close()  # the server's end closes first: its port enters TIME_WAIT
    reserved: int = address[1]
    return reserved
