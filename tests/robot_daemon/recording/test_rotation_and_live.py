"""Rotation under the disk cap, the non-blocking queue, the live Foxglove server, configuration."""

from __future__ import annotations

import base64
import json
import math
import os
import shutil
import socket
import ssl
import struct
import subprocess
import threading
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from foxglove.messages import LaserScan as FoxgloveLaserScan
from mcap.reader import make_reader

from interbot_core.laser_scan import LaserScan
from interbot_core.occupancy_grid import OccupancyGrid
from interbot_core.topics import PoseMsg, Topic
from robot_daemon.config import MB, ConfigError, RecordingConfig, parse_config
from robot_daemon.recording import foxglove_convert as fc
from robot_daemon.recording.daemon_hook import LiveAddressError, build_recorder, parse_live_address
from robot_daemon.recording.recorder import LiveServer, McapRotation, Recorder, RecorderError


def _scan(t: float, rng: np.random.Generator) -> LaserScan:
    # Random ranges compress badly: the file grows as fast as a real scan's would.
    return LaserScan(t, -math.pi / 2, math.pi / 360, 0.02, 30.0, rng.uniform(0.5, 8, 361))


def _small_grid() -> OccupancyGrid:
    cells = np.zeros((40, 60), np.int8)
    cells[0, :] = 100
    cells[10:12, 5:50] = -1
    return OccupancyGrid(cells, 0.05, -1.0, -0.5)


def test_rotation_keeps_the_directory_under_the_cap_and_deletes_the_oldest(tmp_path: Path) -> None:
    config = RecordingConfig(
        directory=str(tmp_path), max_file_mb=0.05, max_total_mb=0.2, queue=100_000
    )
    rng = np.random.default_rng(1)
    clock = iter(range(1_000_000))
    rotation = McapRotation(config, "r1", wall_clock=lambda: 1.7e9 + next(clock))
    sizes_seen = []
    with Recorder("r1", rotation=rotation, queue_size=config.queue) as recorder:
        recorder.state(Topic.MAP, _small_grid(), 0.0)
        for i in range(2400):  # 60 s at 40 Hz: about 2 MB of scans, ten times the cap
            recorder.state(Topic.SCAN, _scan(i / 40, rng), i / 40)
            if i % 200 == 199:
                recorder.flush()
                sizes_seen.append(sum(p.stat().st_size for p in tmp_path.iterdir()))
    files = rotation.recordings()
    assert len(recorder.files) > 10, "the recorder should have rotated many times"
    assert files == recorder.files[-len(files) :], "the newest files are kept, in order"
    assert not recorder.files[0].exists(), "the oldest went first"
    assert max(sizes_seen) <= config.max_total_bytes
    assert sum(p.stat().st_size for p in files) <= config.max_total_bytes
    for path in files:  # every file stands alone: it starts with the map, and is finished
        with path.open("rb") as f:
            reader = make_reader(f)
            topics = [c.topic for _, c, _ in reader.iter_messages()]
            assert reader.get_summary() is not None
        assert topics[0] == "/map" and topics.count("/scan") > 10
        assert path.stat().st_size <= config.max_file_bytes * 1.1


def test_rotation_by_time(tmp_path: Path) -> None:
    config = RecordingConfig(directory=str(tmp_path), max_file_minutes=10 / 60)
    with Recorder("r1", rotation=McapRotation(config, "r1")) as recorder:
        for i in range(35):  # 35 s of 1 Hz poses: files start at 0, 10, 20 and 30 s
            recorder.state(Topic.POSE, PoseMsg(0.0, 0.0, 0.0, float(i)), float(i))
    assert len(recorder.files) == 4
    counts = []
    for path in recorder.files:
        with path.open("rb") as f:
            counts.append(sum(1 for _ in make_reader(f).iter_messages(topics=["/pose"])))
    assert counts == [10, 10, 10, 5]


def test_offers_never_wait_a_full_queue_drops_and_counts(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    rng = np.random.default_rng(2)
    scans = [_scan(i / 40, rng) for i in range(2000)]
    # Hold the writer thread until every offer is made, whatever the machine's load: the queue
    # of 16 is full after 16 offers and the rest must be dropped at once, not waited for.
    gate = threading.Event()
    run = Recorder._run

    def held_writer(self: Recorder) -> None:
        gate.wait(30.0)
        run(self)

    monkeypatch.setattr(Recorder, "_run", held_writer)
    with Recorder("r1", single_file=tmp_path / "x.mcap", queue_size=16) as recorder:
        for scan in scans:
            recorder.state(Topic.SCAN, scan, scan.stamp)
        assert recorder.dropped >= 2000 - 16
        gate.set()
        recorder.flush()
    assert recorder.dropped > 0, "2000 scans offered at once overflow a 16-message queue"
    assert recorder.written + recorder.dropped == 2000
    assert recorder.dropped_by_kind["state"] == recorder.dropped
    # The loss is reported (to the station, by the daemon's link), then again at each doubling.
    report = recorder.health_report()
    assert report is not None and f"{recorder.dropped} messages dropped" in report
    assert recorder.health_report() is None
    recorder.dropped *= 2
    assert recorder.health_report() is not None
    with (tmp_path / "x.mcap").open("rb") as f:
        assert sum(1 for _ in make_reader(f).iter_messages()) == recorder.written + 1  # + mount


def test_live_address_is_loopback_unless_secured() -> None:
    assert parse_live_address("8765") == LiveServer("127.0.0.1", 8765)
    assert parse_live_address("localhost:0") == LiveServer("localhost", 0)
    assert parse_live_address("[::1]:9000") == LiveServer("::1", 9000)
    for bad in ("0.0.0.0:8765", "192.168.1.4:8765", "robot.lan:8765"):
        with pytest.raises(LiveAddressError, match="not loopback"):
            parse_live_address(bad)
    secured = parse_live_address("0.0.0.0:8765", tls=(b"cert", b"key"))
    assert (secured.host, secured.tls_cert, secured.tls_key) == ("0.0.0.0", b"cert", b"key")
    for bad in ("", "x", "127.0.0.1:99999", "127.0.0.1:-1"):
        with pytest.raises(LiveAddressError, match="port"):
            parse_live_address(bad)


def test_recording_section_is_validated(tmp_path: Path) -> None:
    raw = {"directory": "rec", "max_file_mb": 1, "max_total_mb": 10, "camera": False}
    config = parse_config({"recording": raw}, "robot.yaml", tmp_path).recording
    assert config is not None
    assert config.directory == str((tmp_path / "rec").resolve()) and config.max_file_bytes == MB
    assert not config.camera
    bad: list[tuple[dict[str, Any], str]] = [
        ({"directory": "rec", "max_file_mb": 10, "max_total_mb": 10}, "at least twice"),
        ({"directory": "rec", "max_file_mb": "big"}, "must be a number"),
        ({"directory": "rec", "colour": 1}, "unknown key"),
        ({"directory": "rec", "camera": "yes"}, "true or false"),
        ({"directory": "rec", "queue": 1.5}, "integer"),
    ]
    for raw, message in bad:
        with pytest.raises(ConfigError, match=message):
            parse_config({"recording": raw}, "robot.yaml", tmp_path)
    # A section without a directory records only with --record DIR.
    with pytest.raises(RecorderError, match="'directory'"):
        build_recorder("r1", recording=RecordingConfig(), record_dir=None, live=None, now=0.0)
    # Neither recording nor live view asked for: no recorder at all.
    assert build_recorder("r1", recording=None, record_dir=None, live=None, now=0.0) is None


# ----------------------------------------------------------------- a minimal RFC 6455 client


class WebSocketClient:
    """Just enough of RFC 6455 to talk to the Foxglove server: handshake, frames, masking."""

    def __init__(self, port: int, subprotocol: str, tls: ssl.SSLContext | None = None) -> None:
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=5.0)
        if tls is not None:
            self.sock = tls.wrap_socket(self.sock, server_hostname="127.0.0.1")
        key = base64.b64encode(os.urandom(16)).decode()
        self.sock.sendall(
            (
                f"GET / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\n"
                f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
                f"Sec-WebSocket-Version: 13\r\nSec-WebSocket-Protocol: {subprotocol}\r\n\r\n"
            ).encode()
        )
        self.buffer = b""
        while b"\r\n\r\n" not in self.buffer:
            chunk = self.sock.recv(4096)
            if not chunk:
                break
            self.buffer += chunk
        head, _, self.buffer = self.buffer.partition(b"\r\n\r\n")
        self.status_line = head.split(b"\r\n")[0].decode()
        self.headers = head.decode(errors="replace").lower()

    def _complete_frame(self) -> tuple[int, bytes] | None:
        """The first whole frame in the buffer (consumed), or None if it is not all here."""
        buf = self.buffer
        if len(buf) < 2:
            return None
        length, start = buf[1] & 0x7F, 2
        if length == 126:
            if len(buf) < 4:
                return None
            length, start = struct.unpack(">H", buf[2:4])[0], 4
        elif length == 127:
            if len(buf) < 10:
                return None
            length, start = struct.unpack(">Q", buf[2:10])[0], 10
        if len(buf) < start + length:
            return None
        self.buffer = buf[start + length :]
        return buf[0] & 0x0F, buf[start : start + length]

    def frame(self, timeout: float = 5.0) -> tuple[int, bytes] | None:
        """The next frame (opcode, payload), or None after ``timeout`` [s]."""
        self.sock.settimeout(timeout)
        while (frame := self._complete_frame()) is None:
            try:
                chunk = self.sock.recv(65536)
            except TimeoutError:
                return None
            if not chunk:
                raise ConnectionError("server closed the connection")
            self.buffer += chunk
        return frame

    def send_text(self, text: str) -> None:
        payload, mask = text.encode(), os.urandom(4)
        masked = bytes(b ^ mask[i % 4] for i, b in enumerate(payload))
        assert len(payload) < 126
        self.sock.sendall(bytes([0x81, 0x80 | len(payload)]) + mask + masked)

    def close(self) -> None:
        self.sock.close()


def test_live_server_advertises_the_channels_and_streams_scans() -> None:
    rng = np.random.default_rng(3)
    with Recorder("live", live=LiveServer("127.0.0.1", 0)) as recorder:
        port = recorder.port
        assert port is not None and port > 0
        recorder.state(Topic.MAP, _small_grid(), 0.0)
        recorder.state(Topic.SCAN, _scan(0.0, rng), 0.0)
        recorder.state(Topic.POSE, PoseMsg(1.0, 2.0, 0.0, 0.0), 0.0)
        assert recorder.flush()

        refused = WebSocketClient(port, "foxglove.websocket.v1")
        assert " 400 " in refused.status_line + " "  # only foxglove.sdk.v1 is spoken
        refused.close()

        client = WebSocketClient(port, "foxglove.sdk.v1")
        try:
            assert " 101 " in client.status_line, client.status_line
            assert "sec-websocket-protocol: foxglove.sdk.v1" in client.headers
            channels: dict[str, dict[str, Any]] = {}
            ops = []
            while not {"/map", "/scan", "/pose", "/tf_static"} <= set(channels):
                frame = client.frame()
                assert frame is not None, f"no advertisement of every channel: {channels}"
                opcode, payload = frame
                assert opcode == 1, "control messages are JSON text frames"
                message = json.loads(payload)
                ops.append(message["op"])
                if message["op"] == "advertise":
                    channels.update({c["topic"]: c for c in message["channels"]})
            assert ops[0] == "serverInfo"
            assert channels["/scan"]["schemaName"] == "foxglove.LaserScan"
            assert channels["/map"]["schemaName"] == "foxglove.Grid"
            assert channels["/pose"]["encoding"] == "json"

            sub = {
                "op": "subscribe",
                "subscriptions": [{"id": 7, "channelId": channels["/scan"]["id"]}],
            }
            client.send_text(json.dumps(sub))
            scan = _scan(0.025, rng)
            frame = None
            for _ in range(50):  # until the server has processed the subscription
                recorder.state(Topic.SCAN, scan, 0.025)
                recorder.flush()
                frame = client.frame(timeout=0.1)
                if frame is not None and frame[0] == 2:
                    break
            assert frame is not None, "no message data after subscribing"
            opcode, payload = frame
            assert opcode == 2 and payload[0] == 0x01  # binary MessageData
            subscription, _log_time = struct.unpack_from("<IQ", payload, 1)
            assert subscription == 7
            schema = FoxgloveLaserScan.get_schema()  # the schema the server advertised
            message = fc.message_class(schema.name, schema.data).FromString(payload[13:])
            decoded = fc.scan_from(message, 0.02, 30.0)
            np.testing.assert_allclose(decoded.ranges, scan.ranges, rtol=1e-6)
        finally:
            client.close()


def test_daemon_refuses_a_non_loopback_foxglove_address(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    import signal

    from robot_daemon.main import main

    monkeypatch.setattr(signal, "signal", lambda *_: None)  # keep pytest's handlers

    status = main(
        ["--sim", "--people", "0", "--listen", "tcp/127.0.0.1:0", "--foxglove", "0.0.0.0:8765"]
    )
    assert status == 2
    assert "not loopback" in capsys.readouterr().err


def test_the_deployed_robot_yaml_records_every_run(repo_root: Path, tmp_path: Path) -> None:
    from robot_daemon.config import load_config
    from robot_daemon.daemon import DaemonOptions
    from robot_daemon.recording.daemon_hook import build_daemon_recorder

    config = load_config(repo_root / "deploy" / "robot.yaml")
    recording = config.recording
    assert recording is not None and recording.directory == "/var/lib/interbot/recordings"
    assert recording.max_total_bytes == 8192 * MB and recording.camera
    # --record DIR keeps the section's limits but writes to DIR.
    recorder = build_daemon_recorder(config, DaemonOptions(record_dir=tmp_path), 0.0)
    assert recorder is not None
    recorder.close()
    assert recorder.files[0].parent == tmp_path
    with pytest.raises(ConfigError, match="max_total_mb"):
        parse_config({"recording": {"directory": "x", "max_total_mb": -1}}, "robot.yaml", tmp_path)
    no_directory = config.with_overrides(recording=RecordingConfig())
    with pytest.raises(ConfigError, match="'directory'"):
        build_daemon_recorder(no_directory, DaemonOptions(), 0.0)


@pytest.mark.skipif(shutil.which("openssl") is None, reason="needs the openssl command")
def test_a_tls_live_server_speaks_wss_with_its_pinned_certificate(tmp_path: Path) -> None:
    cert, key = tmp_path / "cert.pem", tmp_path / "key.pem"
    subprocess.run(
        ["openssl", "req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:P-256",
         "-nodes", "-days", "1", "-subj", "/CN=127.0.0.1", "-addext", "subjectAltName=IP:127.0.0.1",
         "-keyout", str(key), "-out", str(cert)],
        check=True, capture_output=True,
    )  # fmt: skip
    live = LiveServer("127.0.0.1", 0, tls_cert=cert.read_bytes(), tls_key=key.read_bytes())
    with Recorder("tls", live=live) as recorder:
        recorder.state(Topic.POSE, PoseMsg(1.0, 2.0, 0.0, 0.0), 0.0)
        assert recorder.flush() and recorder.port
        pinned = ssl.create_default_context(cafile=str(cert))
        client = WebSocketClient(recorder.port, "foxglove.sdk.v1", tls=pinned)
        try:
            assert " 101 " in client.status_line
            frame = client.frame()
            assert frame is not None and json.loads(frame[1])["op"] == "serverInfo"
        finally:
            client.close()
        try:  # plain ws:// is refused: a TLS alert instead of "101 Switching Protocols"
            plain = WebSocketClient(recorder.port, "foxglove.sdk.v1")
            refused = " 101 " not in plain.status_line
            plain.close()
        except OSError:
            refused = True
        assert refused
