"""Fixtures for the Tablet tests: a small floor plan on disk, a fake Base Station on
127.0.0.1 (port chosen by the OS) and a connected Tablet window."""

from __future__ import annotations

import logging
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from PySide6.QtCore import QObject, Signal
from PySide6.QtNetwork import QHostAddress, QTcpServer, QTcpSocket

from interbot_core.occupancy_grid import write_pgm
from interbot_core.protocol import JsonStreamDecoder, Message, Pong, encode
from tablet_app.link_health import BackoffConfig, LatencyConfig

logger = logging.getLogger(__name__)

# The offscreen platform warns on every top-level window; that is not a failure.
OFFSCREEN_NOISE = "This plugin does not support propagateSizeHints"

TOPO_YAML = """\
map: floor.yaml
nodes:
  - {id: 0, name: Entrance, x: 1.0, y: 1.0, yaw: 0.0, info: "The main entrance.", tour: true,
     home: true, area: [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]],
     name_pt: Entrada, info_pt: "A entrada principal."}
  - {id: 1, name: Corridor corner, x: 5.0, y: 1.0, yaw: 0.0, area: [],
     name_pt: Canto do corredor}
  - {id: 2, name: Lab door, x: 8.0, y: 1.0, yaw: 1.57,
     area: [[7.0, 2.0], [10.0, 2.0], [10.0, 5.0], [7.0, 5.0]], name_pt: Porta do laboratório}
  - {id: 3, name: Lab, x: 8.5, y: 3.5, yaw: 1.57, info: "Robots are built here.", tour: true,
     requests: true, area: [[7.0, 2.0], [10.0, 2.0], [10.0, 5.0], [7.0, 5.0]],
     name_pt: Laboratório, info_pt: "Aqui constroem-se robôs."}
  - {id: 4, name: Office, x: 3.0, y: 4.0, yaw: 3.14, info: "The director's office.",
     tour: true, requests: true, area: [[2.0, 3.0], [5.0, 3.0], [5.0, 5.0], [2.0, 5.0]],
     name_pt: Gabinete, info_pt: "O gabinete do diretor."}
"""

MAP_YAML = """\
image: floor.pgm
resolution: 0.1
origin: [0.0, 0.0, 0.0]
negate: 0
occupied_thresh: 0.65
free_thresh: 0.196
"""


@pytest.fixture
def topo_path(tmp_path: Path) -> Path:
    image = np.full((60, 110), 254, dtype=np.uint8)  # 11 m x 6 m, free
    image[0, :] = image[-1, :] = image[:, 0] = image[:, -1] = 0  # walls
    write_pgm(tmp_path / "floor.pgm", image)
    (tmp_path / "floor.yaml").write_text(MAP_YAML, encoding="utf-8")
    path = tmp_path / "topo.yaml"
    path.write_text(TOPO_YAML, encoding="utf-8")
    return path


FAST_LATENCY = LatencyConfig(window=5, pong_timeout=0.4, ceiling=0.3)
FAST_BACKOFF = BackoffConfig(initial=0.05, maximum=0.2)


def commands(station: Any) -> list[dict[str, Any]]:
    """What the tablet sent, without the latency pings/pongs."""
    return [obj for obj in station.received if not ({"ping", "pong"} & obj.keys())]


@pytest.fixture
def station(qapp: Any) -> Iterator[Any]:
    fake = FakeStation()
    fake.listen()
    yield fake
    fake.close()
    fake.deleteLater()


@pytest.fixture
def connection(qtbot: Any, station: Any) -> Iterator[Any]:
    from tablet_app.tablet_connection import TabletConnection

    conn = TabletConnection(
        "127.0.0.1",
        station.port,
        ping_interval=0.1,
        health_interval=0.05,
        latency=FAST_LATENCY,
        backoff=FAST_BACKOFF,
    )
    yield conn
    conn.stop()
    conn.deleteLater()


@pytest.fixture
def window(qtbot: Any, station: Any, connection: Any, topo_path: Path) -> Any:
    """A shown Tablet window connected to the fake station, the hello already received."""
    from tablet_app.main import load_plan
    from tablet_app.main_window import TabletWindow

    plan, grid = load_plan(topo_path)
    win = TabletWindow(connection, plan, grid)
    qtbot.addWidget(win)
    win.resize(1280, 800)
    win.show()
    connection.start()
    qtbot.waitUntil(lambda: bool(station.messages("hello")))
    return win


# ------------------------------------------------------------------ the fake Base Station
# A test double: an in-process stand-in for the station's tablet server (moved out of the
# product package). It records what tablets send and sends what a test asks.
class FakeStation(QObject):
    """Records what tablets send; ``send``/``send_raw`` go to the newest client."""

    client_connected = Signal()
    object_received = Signal(object)

    def __init__(self, parent: QObject | None = None, answer_pings: bool = True) -> None:
        super().__init__(parent)
        self.answer_pings = answer_pings
        self.received: list[dict[str, Any]] = []
        self.raw = bytearray()
        self._server = QTcpServer(self)
        self._server.newConnection.connect(self._on_new_connection)
        self._client: QTcpSocket | None = None
        self._decoder = JsonStreamDecoder()
        self.clients_seen = 0

    def listen(self, port: int = 0) -> int:
        if not self._server.listen(QHostAddress(QHostAddress.SpecialAddress.LocalHost), port):
            raise OSError(f"fake station cannot listen: {self._server.errorString()}")
        return self.port

    @property
    def port(self) -> int:
        return int(self._server.serverPort())

    @property
    def has_client(self) -> bool:
        return (
            self._client is not None
            and self._client.state() == QTcpSocket.SocketState.ConnectedState
        )

    def close(self) -> None:
        """Stop listening and drop the client (the tablet sees a disconnect)."""
        self._server.close()
        if self._client is not None:
            self._client.abort()
            self._client.deleteLater()
            self._client = None

    def drop_client(self) -> None:
        if self._client is not None:
            self._client.disconnectFromHost()

    def send(self, msg: Message) -> None:
        self.send_raw(encode(msg))

    def send_raw(self, data: bytes) -> None:
        if self._client is None:
            raise RuntimeError("no tablet is connected to the fake station")
        self._client.write(data)
        self._client.flush()

    def messages(self, key: str) -> list[Any]:
        """Bodies of every received message with top-level ``key``, in order."""
        return [obj[key] for obj in self.received if key in obj]

    def clear(self) -> None:
        self.received.clear()
        self.raw.clear()

    def _on_new_connection(self) -> None:
        while self._server.hasPendingConnections():
            socket = self._server.nextPendingConnection()
            if self._client is not None:
                self._client.abort()
                self._client.deleteLater()
            self._client = socket
            self._decoder.reset()
            self.clients_seen += 1
            socket.readyRead.connect(self._on_ready_read)
            self.client_connected.emit()

    def _on_ready_read(self) -> None:
        if self._client is None:
            return
        data = bytes(self._client.readAll().data())
        self.raw += data
        for item in self._decoder.feed(data):
            if not isinstance(item, dict):
                logger.warning("fake station got a bad frame: %s", item)
                continue
            self.received.append(item)
            if self.answer_pings and "ping" in item:
                self.send_raw(encode_pong(item["ping"]))
            self.object_received.emit(item)


def encode_pong(ping_body: dict[str, Any]) -> bytes:
    return encode(Pong(int(ping_body["seq"]), float(ping_body["t"])))
