"""TLS and pairing in front of the tablet server (issue 15; docs/security.md).

`TabletAuthServer` is the `QTcpServer` that `TabletServer` listens with when security is on.
Each incoming connection becomes a `QSslSocket` with the station's own certificate and key
(the tablet pins that certificate's SHA-256 digest). After the TLS handshake the tablet has
``handshake_timeout_ms`` to send ONE frame, ``pair`` (one-time code) or ``auth`` (its token);
`interbot_core.tablet_pairing.TabletRegistry` decides. Refused connections get the protocol's
``{"refused": {"reason": ...}}`` and are closed; nothing they sent reaches `TabletServer`.
Accepted sockets are handed over with ``addPendingConnection`` (``pendingConnectionAvailable``),
so the protocol inside (hello, speed, ping ...) and every policy of `TabletServer` are unchanged.

Revoking a tablet (`revoke`) also drops its live connection. The server lives in the tablet
server's thread (issue 14); `new_offer` and `revoke`, called by the pairing panel on the Qt
thread, run in the server's thread (`ThreadCall`). The registry is saved as JSON
(mode 0600) beside the station's keys; it holds token digests, never tokens.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import secrets
from collections.abc import Callable
from pathlib import Path

from PySide6.QtCore import QByteArray, QCryptographicHash, QObject, QTimer, Signal
from PySide6.QtNetwork import (
    QAbstractSocket,
    QNetworkInterface,
    QSsl,
    QSslCertificate,
    QSslConfiguration,
    QSslKey,
    QSslSocket,
    QTcpServer,
    QTcpSocket,
)

from interbot_core.protocol import JsonStreamDecoder, ProtocolError, Refused, encode
from interbot_core.tablet_pairing import (
    PairingError,
    PairingOffer,
    TabletRecord,
    TabletRegistry,
    decode_auth_frame,
)
from interbot_qt.thread_call import ThreadCall

logger = logging.getLogger(__name__)

HANDSHAKE_TIMEOUT_MS = 5000
MAX_AUTH_FRAME = 4096  # [bytes] a pair/auth frame is < 200 bytes
MAX_PENDING = 8  # connections between accept and authorisation (a flood gets no more)


class TabletTlsError(RuntimeError):
    """The station's certificate or key cannot be used for the tablet link."""


def _frame(obj: dict[str, object]) -> bytes:
    return json.dumps(obj, separators=(",", ":")).encode() + b"\n"


def advertised_address(host: str) -> str:
    """``host``, or for a wildcard listen (0.0.0.0, ::) this machine's first non-loopback IPv4."""
    if host not in ("0.0.0.0", "::", ""):
        return host
    for address in QNetworkInterface.allAddresses():
        if address.protocol() == QAbstractSocket.NetworkLayerProtocol.IPv4Protocol and not (
            address.isLoopback()
        ):
            return str(address.toString())
    return "127.0.0.1"


def load_registry(path: Path) -> TabletRegistry:
    """The paired tablets saved at ``path`` (a new, empty registry if there is none)."""
    if not path.exists():
        return TabletRegistry(secrets.token_bytes)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise PairingError(f"cannot read the paired tablets from {path}: {exc}") from None
    return TabletRegistry.from_json(data, secrets.token_bytes)


class _PendingTablet(QObject):
    """One connection between accept and authorisation."""

    def __init__(self, server: TabletAuthServer, socket: QSslSocket, timeout_ms: int) -> None:
        super().__init__(server)
        self.server = server
        self.socket = socket
        socket.setParent(self)  # dies with this handshake unless handed over
        self.peer = f"{socket.peerAddress().toString()}:{socket.peerPort()}"
        self.decoder = JsonStreamDecoder(MAX_AUTH_FRAME)
        self.timer = QTimer(self)
        self.timer.setSingleShot(True)
        self.timer.timeout.connect(self.on_timeout)
        self.timer.start(timeout_ms)
        socket.readyRead.connect(self.on_ready_read)
        socket.sslErrors.connect(self.on_ssl_errors)
        socket.errorOccurred.connect(self.on_error)
        socket.disconnected.connect(self.on_disconnected)

    def detach(self) -> None:
        self.timer.stop()
        self.socket.readyRead.disconnect(self.on_ready_read)
        self.socket.sslErrors.disconnect(self.on_ssl_errors)
        self.socket.errorOccurred.disconnect(self.on_error)
        self.socket.disconnected.disconnect(self.on_disconnected)
        self.socket.setParent(self.server)
        self.deleteLater()

    def refuse(self, reason: str) -> None:
        self.timer.stop()
        logger.warning("refusing tablet %s: %s", self.peer, reason)
        self.server.auth_refused.emit(self.peer, reason)
        if self.socket.isEncrypted():
            self.socket.write(encode(Refused(reason)))
        self.socket.disconnectFromHost()
        if self.socket.state() != QAbstractSocket.SocketState.UnconnectedState:
            QTimer.singleShot(1000, self.socket, self.socket.abort)

    def on_timeout(self) -> None:
        self.refuse("no pairing code or tablet token within the time allowed")

    def on_ssl_errors(self, errors: list[object]) -> None:
        logger.warning("TLS errors with tablet %s: %s", self.peer, errors)

    def on_error(self, _error: QAbstractSocket.SocketError) -> None:
        if not self.socket.isEncrypted():
            reason = f"TLS handshake failed: {self.socket.errorString()}"
            logger.warning("tablet %s: %s", self.peer, reason)
            self.server.auth_refused.emit(self.peer, reason)

    def on_disconnected(self) -> None:
        self.timer.stop()
        self.deleteLater()  # and the socket, its child

    def on_ready_read(self) -> None:
        items = self.decoder.feed(bytes(self.socket.readAll().data()))
        if not items:
            return
        if len(items) > 1:
            self.refuse("send nothing before the station has answered pair or auth")
            return
        item = items[0]
        if isinstance(item, ProtocolError):
            self.refuse(f"bad first frame: {item.message}")
            return
        try:
            request = decode_auth_frame(item)
            record, token = self.server.authorise(request.kind, request.secret, request.name)
        except PairingError as exc:
            self.refuse(str(exc))
            return
        self.detach()
        self.server.admit(self.socket, record, token)


class TabletAuthServer(QTcpServer):
    """A `QTcpServer` whose pending connections are TLS sockets of paired tablets.

    Signals: ``tablets_changed()`` (paired, revoked), ``auth_refused(peer, reason)``,
    ``tablet_authorised(record)``.
    """

    tablets_changed = Signal()
    auth_refused = Signal(str, str)
    tablet_authorised = Signal(object)

    def __init__(
        self,
        cert_pem: bytes,
        key_pem: bytes,
        registry: TabletRegistry,
        clock: Callable[[], float],
        *,
        registry_path: Path | None = None,
        handshake_timeout_ms: int = HANDSHAKE_TIMEOUT_MS,
        parent: QObject | None = None,
    ) -> None:
        super().__init__(parent)
        certificate = QSslCertificate(QByteArray(cert_pem), QSsl.EncodingFormat.Pem)
        key = QSslKey(QByteArray(key_pem), QSsl.KeyAlgorithm.Ec, QSsl.EncodingFormat.Pem)
        if certificate.isNull() or key.isNull():
            raise TabletTlsError("the station's certificate or EC private key cannot be read")
        config = QSslConfiguration.defaultConfiguration()
        config.setLocalCertificate(certificate)
        config.setPrivateKey(key)
        config.setProtocol(QSsl.SslProtocol.TlsV1_2OrLater)
        config.setPeerVerifyMode(QSslSocket.PeerVerifyMode.VerifyNone)  # tablets use tokens
        self._config = config
        sha256 = QCryptographicHash.Algorithm.Sha256
        self.fingerprint = bytes(certificate.digest(sha256).data()).hex()
        self.registry = registry
        self.clock = clock  # [s] what pairing codes expire on
        self._path = registry_path
        self._timeout = handshake_timeout_ms
        self._live: dict[str, list[QSslSocket]] = {}
        self.offer: PairingOffer | None = None
        self.advertised_host = "127.0.0.1"
        """The address tablets are told to connect to (shown in the pairing QR code)."""
        self._call = ThreadCall(self)

    @classmethod
    def from_files(
        cls,
        cert_path: Path,
        key_path: Path,
        registry_path: Path,
        clock: Callable[[], float],
        parent: QObject | None = None,
    ) -> TabletAuthServer:
        try:
            cert, key = cert_path.read_bytes(), key_path.read_bytes()
        except OSError as exc:
            raise TabletTlsError(f"cannot read the station's certificate: {exc}") from None
        registry = load_registry(registry_path)
        return cls(cert, key, registry, clock, registry_path=registry_path, parent=parent)

    # ------------------------------------------------------------------ Qt
    def incomingConnection(self, handle: int) -> None:  # Qt override
        pending = self.findChildren(_PendingTablet)
        if len(pending) >= MAX_PENDING:
            logger.warning("%d tablet handshakes pending: dropping a new connection", len(pending))
            extra = QTcpSocket(self)
            extra.setSocketDescriptor(handle)  # adopt it only to close it at once
            extra.abort()
            extra.deleteLater()
            return
        socket = QSslSocket(self)
        if not socket.setSocketDescriptor(handle):
            logger.warning("cannot adopt a tablet connection: %s", socket.errorString())
            socket.deleteLater()
            return
        socket.setSslConfiguration(self._config)
        _PendingTablet(self, socket, self._timeout)
        socket.startServerEncryption()

    # ------------------------------------------------------------------ pairing
    def new_offer(self, host: str | None = None) -> PairingOffer:
        """A fresh one-time code for a tablet to pair with (shown with its QR code)."""
        return self._call.run(lambda: self._new_offer_now(host))

    def _new_offer_now(self, host: str | None) -> PairingOffer:
        host = host or self.advertised_host
        code, expires = self.registry.new_code(self.clock())
        self.offer = PairingOffer(host, int(self.serverPort()), self.fingerprint, code, expires)
        return self.offer

    def authorise(self, kind: str, secret: str, name: str) -> tuple[TabletRecord, str | None]:
        """Pair (``kind`` "pair": returns the new token) or authenticate (``"auth"``: None).

        Raises PairingError (its text is sent to the tablet) when refused.
        """
        if kind == "pair":
            record, token = self.registry.pair(secret, name, self.clock())
            self.offer = None
            self._save()
            self.tablets_changed.emit()
            return record, token
        return self.registry.authenticate(secret), None

    def admit(self, socket: QSslSocket, record: TabletRecord, token: str | None) -> None:
        """Answer ``paired`` / ``authorised`` and hand the socket to `TabletServer`."""
        reply: dict[str, object]
        if token is not None:
            reply = {"paired": {"tablet_id": record.tablet_id, "token": token}}
        else:
            reply = {"authorised": {"tablet_id": record.tablet_id}}
        socket.write(_frame(reply))
        self._live.setdefault(record.tablet_id, []).append(socket)
        socket.destroyed.connect(lambda *_: self._forget(record.tablet_id, socket))
        logger.info("tablet %s (%s) authorised", record.tablet_id, record.name)
        self.tablet_authorised.emit(record)
        self.addPendingConnection(socket)

    def _forget(self, tablet_id: str, socket: QSslSocket) -> None:
        sockets = self._live.get(tablet_id, [])
        if socket in sockets:
            sockets.remove(socket)

    def revoke(self, tablet_id: str) -> TabletRecord:
        """Revoke a tablet's token and drop its live connections at once."""
        return self._call.run(lambda: self._revoke_now(tablet_id))

    def _revoke_now(self, tablet_id: str) -> TabletRecord:
        record = self.registry.revoke(tablet_id)
        self._save()
        for socket in list(self._live.pop(tablet_id, [])):
            with contextlib.suppress(RuntimeError):  # already deleted by Qt
                socket.abort()
        self.tablets_changed.emit()
        return record

    def _save(self) -> None:
        if self._path is None:
            return
        tmp = self._path.with_name(self._path.name + ".tmp")
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            json.dump(self.registry.to_json(), f, indent=1)
        tmp.replace(self._path)
