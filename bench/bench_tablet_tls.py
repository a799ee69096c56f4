"""Benchmark: what TLS and pairing cost on the tablet link (issue 15), in isolation.

The station's real `TabletServer` in this process, plaintext or behind `TabletAuthServer` (TLS
with the station's certificate, a paired token); a tablet thread with a blocking Python socket
(TCP_NODELAY; TLS pinned on the station's certificate, then ``auth``) sends ``ping`` and waits
for the ``pong`` the station answers on its Qt event loop, one in flight at a time, for both
variants in turn. ``tablet_rtt_plain_ms_*`` / ``tablet_rtt_tls_ms_*`` are those round trips;
``tablet_tls_connect_ms_*`` is connect + TLS handshake + token check until ``authorised``.

    .venv/bin/interbot bench --only tablet_tls --json
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import os
import secrets
import socket
import ssl
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

_spec = importlib.util.spec_from_file_location("interbot_bench_common", Path(__file__).with_name("_common.py"))  # fmt: skip
common = importlib.util.module_from_spec(_spec)  # type: ignore[arg-type]
_spec.loader.exec_module(common)  # type: ignore[union-attr]

SAMPLES = 500
QUICK_SAMPLES = 30
CONNECTS = 20
QUICK_CONNECTS = 3


def run(quick: bool = False) -> dict[str, Any]:
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    n, connects = (QUICK_SAMPLES, QUICK_CONNECTS) if quick else (SAMPLES, CONNECTS)
    with common.quiet_logs(), tempfile.TemporaryDirectory(prefix="interbot-bench-") as tmp:
        from interbot_link import KeyStore

        keys = KeyStore.init(Path(tmp) / "keys").dir
        out: dict[str, Any] = {}
        plain, _ = _measure(None, n, 0)
        rtt, connect = _measure(keys, n, connects)
        out.update(common.summary_ms(plain, "tablet_rtt_plain", median_name="p50"))
        out.update(common.summary_ms(rtt, "tablet_rtt_tls", median_name="p50"))
        out.update(common.summary_ms(connect, "tablet_tls_connect", median_name="p50"))
        return out


def _measure(keys: Path | None, n: int, connects: int) -> tuple[list[float], list[float]]:
    from PySide6.QtCore import QEventLoop, QTimer
    from PySide6.QtWidgets import QApplication

    from base_station_app.tablet_auth import TabletAuthServer
    from base_station_app.tablet_server import TabletServer
    from interbot_core.tablet_pairing import TabletRegistry

    app = QApplication.instance() or QApplication([])
    auth, token, fingerprint = None, "", ""
    if keys is not None:
        registry = TabletRegistry(secrets.token_bytes)
        code, _ = registry.new_code(time.time())
        _, token = registry.pair(code, "bench tablet", time.time())
        cert, key = (keys / "station.crt").read_bytes(), (keys / "station.key").read_bytes()
        auth = TabletAuthServer(cert, key, registry, time.time)
        fingerprint = auth.fingerprint
    server = TabletServer(time.monotonic, "127.0.0.1", 0, server=auth, ping_interval_ms=3_600_000)
    if not server.listen():
        raise RuntimeError("bench_tablet_tls: cannot listen")
    port = server.port
    loop = QEventLoop()
    rtts: list[float] = []
    connect_times: list[float] = []
    failure: list[BaseException] = []

    def open_tablet() -> socket.socket:
        t0 = time.perf_counter()
        raw = socket.create_connection(("127.0.0.1", port), timeout=10.0)
        raw.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        if keys is None:
            return raw
        context = ssl.SSLContext(ssl.PROTOCOL_TLS_CLIENT)
        context.check_hostname = False
        context.verify_mode = ssl.CERT_NONE  # pinned below, as tablet_app.pairing does
        tls = context.wrap_socket(raw)
        der = tls.getpeercert(binary_form=True) or b""
        if hashlib.sha256(der).hexdigest() != fingerprint:
            raise RuntimeError("bench_tablet_tls: the station's certificate is not the pinned one")
        tls.sendall(json.dumps({"auth": {"token": token}}).encode() + b"\n")
        reply = b""
        while b"\n" not in reply:
            reply += tls.recv(4096)
        if b"authorised" not in reply:
            raise RuntimeError(f"bench_tablet_tls: not authorised: {reply!r}")
        connect_times.append(time.perf_counter() - t0)
        return tls

    def tablet() -> None:
        try:
            for _ in range(connects - 1):  # the last connection is the measured one
                open_tablet().close()
                time.sleep(0.05)  # the station drops the previous tablet first
            sock = open_tablet()
            buffer = b""
            for i in range(n):
                t0 = time.perf_counter()
                sock.sendall(json.dumps({"ping": {"seq": i + 1, "t": 1.0}}).encode() + b"\n")
                while b"pong" not in buffer:
                    chunk = sock.recv(4096)
                    if not chunk:
                        raise RuntimeError("bench_tablet_tls: the station closed the tablet")
                    buffer += chunk
                rtts.append(time.perf_counter() - t0)
                buffer = b""
            sock.close()
        except BaseException as exc:  # reported in the caller's thread
            failure.append(exc)
        finally:
            QTimer.singleShot(0, loop, loop.quit)

    thread = threading.Thread(target=tablet, daemon=True)
    thread.start()
    loop.exec()
    thread.join(10.0)
    server.close()
    app.processEvents()
    if failure:
        raise failure[0]
    return rtts, connect_times


if __name__ == "__main__":
    print(json.dumps(run(), indent=2))  # command-line output
