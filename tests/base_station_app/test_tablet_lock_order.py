"""The tablet thread never waits for a Qt object mutex while holding the GIL (a station freeze).

Seen in the 10th loop of the end-to-end task tests under load: the whole process froze with the
tablet thread in ``TabletServer._on_object`` at ``self.sender()`` (PySide keeps the GIL; Qt
locks the server's signal-slot mutex) and the Qt thread in a disconnect (pytest-qt's wait
dropping its timer's connection), which holds such a mutex while it calls the sender's
``disconnectNotify`` and PySide's wrapper waits there for the GIL. Every other thread (the
daemon loop, its command thread, zenoh's callbacks) then waited for the GIL too.

The test holds the server's mutex on purpose, the way Qt does: a subclass whose
``disconnectNotify`` waits while another thread disconnects from the server. A tablet's
``ping`` must still be answered. It runs in a child process: with the old code the child
freezes for good (no Python thread can run, so neither can pytest-timeout), and the test
fails when the child does not finish in time.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
CHILD_TIMEOUT_S = 60.0  # starting Python and Qt under load takes a few seconds of it

CHILD = r"""
import json, socket, threading, time
from PySide6.QtCore import QCoreApplication
from base_station_app.tablet_server import TabletServer
from interbot_core.protocol import PROTOCOL_VERSION, Hello, Ping, encode

app = QCoreApplication([])
inside, release = threading.Event(), threading.Event()


class HeldServer(TabletServer):
    hold = False

    def disconnectNotify(self, signal):  # Qt calls it with the server's mutex locked
        if self.hold:
            inside.set()
            release.wait(30)


server = HeldServer(time.monotonic, port=0, ping_interval_ms=600_000)
server.start_thread()
assert server.listen()
client = socket.create_connection(("127.0.0.1", server.port), timeout=20)
reader = client.makefile("rb")
client.sendall(encode(Hello(PROTOCOL_VERSION, "lock-order test")))
assert "welcome" in json.loads(reader.readline())
connection = server.refused.connect(lambda peer, reason: None)
server.hold = True
helper = threading.Thread(target=server.refused.disconnect, args=(connection,))
helper.start()
assert inside.wait(20), "disconnectNotify was not called"
client.sendall(encode(Ping(7, 1.5)))
print("answer", reader.readline().decode().strip(), flush=True)
release.set()
helper.join()
server.hold = False
client.close()
server.stop_thread()
"""


def test_the_tablet_thread_answers_while_a_disconnect_holds_the_servers_mutex() -> None:
    env = {**os.environ, "QT_QPA_PLATFORM": "offscreen"}
    try:
        child = subprocess.run(
            [sys.executable, "-c", CHILD],
            cwd=ROOT,
            env=env,
            capture_output=True,
            text=True,
            timeout=CHILD_TIMEOUT_S,
        )
    except subprocess.TimeoutExpired as exc:
        pytest.fail(
            f"the station froze: no answer to the tablet's ping in {CHILD_TIMEOUT_S:.0f} s "
            f"while another thread held the server's signal-slot mutex; output: {exc.stdout!r}"
        )
    assert child.returncode == 0, child.stderr
    assert 'answer {"pong":{"seq":7,"t":1.5}}' in child.stdout, (child.stdout, child.stderr)
