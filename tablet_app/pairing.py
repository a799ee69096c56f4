"""The tablet's end of the secure link: TLS pinned on the station's certificate, then a token.

`PairedTlsConnection` is a `QtTcpConnection` over a `QSslSocket`. It connects encrypted, checks
that the station's certificate has the SHA-256 digest the tablet was paired with (anything else
is dropped before a byte is sent), sends ONE frame, ``pair`` with the one-time code the station
showed (first time) or ``auth`` with the token it then received, and only when the station
answers ``paired`` / ``authorised`` emits ``connected``: from there on the thesis's JSON
protocol runs unchanged inside TLS (`TabletConnection` does not know the difference). A refusal
(``{"refused": ...}``: wrong code, revoked tablet) is passed on as the protocol's ``refused``
message and the connection is closed.

`TabletCredentials` is what pairing leaves on the tablet (host, port, fingerprint, token), kept
in a JSON file readable by its owner only. See docs/security.md.
"""

from __future__ import annotations

import json
import logging
import os
from pathlib import Path
from typing import Annotated

import msgspec
from msgspec import Meta
from PySide6.QtCore import QCryptographicHash, QObject, Signal
from PySide6.QtNetwork import QAbstractSocket, QSsl, QSslConfiguration, QSslSocket

from interbot_core import schema
from interbot_core.protocol import ProtocolError
from interbot_core.tablet_pairing import (
    PairingError,
    auth_frame,
    normalise_fingerprint,
    pair_frame,
)
from interbot_qt.qt_tcp_connection import QtTcpConnection

logger = logging.getLogger(__name__)

DEFAULT_CREDENTIALS = Path("~/.config/interbot/tablet.json")


class TabletCredentials(msgspec.Struct, frozen=True, forbid_unknown_fields=True):
    """A paired tablet's link to its station (the file is declared by these types)."""

    host: Annotated[str, Meta(min_length=1, max_length=253)]
    port: Annotated[int, Meta(ge=1, le=65535)]
    fingerprint: str  # SHA-256 of the station's certificate (checked by normalise_fingerprint)
    token: Annotated[str, Meta(pattern=r"^[0-9a-f]{64}$")]
    tablet_id: str

    def save(self, path: Path) -> None:
        path = path.expanduser()
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(path.name + ".tmp")
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        with os.fdopen(fd, "wb") as f:
            f.write(msgspec.json.format(msgspec.json.encode(self), indent=1))
        tmp.replace(path)

    @classmethod
    def load(cls, path: Path) -> TabletCredentials:
        path = path.expanduser()
        try:
            data = schema.parse_json(path.read_bytes())
            creds = schema.convert(data, cls, "credentials")
        except (OSError, ValueError) as exc:
            raise PairingError(f"cannot read the tablet's pairing from {path}: {exc}") from None
        normalise_fingerprint(creds.fingerprint)
        return creds


class PairedTlsConnection(QtTcpConnection):
    """JSON over TLS to a pinned station, after pairing or token authentication.

    Extra signals: ``paired(TabletCredentials)`` once a one-time code was accepted (save it),
    ``auth_failed(str)`` when the station's certificate does not match or it refuses us.
    """

    paired = Signal(object)
    auth_failed = Signal(str)

    def __init__(
        self,
        fingerprint: str,
        *,
        token: str | None = None,
        pairing_code: str | None = None,
        name: str = "tablet",
        parent: QObject | None = None,
    ) -> None:
        if (token is None) == (pairing_code is None):
            raise ValueError("give exactly one of token and pairing_code")
        self.fingerprint = normalise_fingerprint(fingerprint)
        self._token = token
        self._code = pairing_code
        self._name = name
        self._authorised = False
        self._host, self._port = "", 0
        socket = QSslSocket()
        config = QSslConfiguration.defaultConfiguration()
        config.setProtocol(QSsl.SslProtocol.TlsV1_2OrLater)
        # The chain is not checked against system CAs: the pin below is the trust decision.
        config.setPeerVerifyMode(QSslSocket.PeerVerifyMode.VerifyNone)
        socket.setSslConfiguration(config)
        super().__init__(socket, parent)
        socket.encrypted.connect(self._on_encrypted)
        self._ssl = socket

    @property
    def is_connected(self) -> bool:
        return super().is_connected and self._authorised

    def connect_to_host(self, host: str, port: int) -> None:
        self._decoder.reset()
        self._authorised = False
        self._host, self._port = host, port
        self._ssl.connectToHostEncrypted(host, port)

    # ---------------------------------------------------------------- overrides
    def _on_connected(self) -> None:
        """TCP is up; TLS and authentication are not: say nothing yet."""
        self._set_low_delay()
        self._decoder.reset()

    def _on_encrypted(self) -> None:
        digest = self._ssl.peerCertificate().digest(QCryptographicHash.Algorithm.Sha256)
        seen = bytes(digest.data()).hex()
        if seen != self.fingerprint:
            self._fail(
                f"the station's certificate ({seen[:16]}...) is not the one this tablet was "
                f"paired with ({self.fingerprint[:16]}...): not connecting (pair again if the "
                "station's keys were renewed)"
            )
            return
        frame = pair_frame(self._code, self._name) if self._code else auth_frame(str(self._token))
        self._ssl.write(json.dumps(frame, separators=(",", ":")).encode() + b"\n")

    def _on_ready_read(self) -> None:
        if self._authorised:
            super()._on_ready_read()
            return
        items = self._decoder.feed(bytes(self._ssl.readAll().data()))
        if not items:
            return
        first, rest = items[0], items[1:]
        if isinstance(first, ProtocolError) or not isinstance(first, dict):
            self._fail("the station's answer to pairing is not valid JSON")
            return
        if "refused" in first:
            reason = str((first.get("refused") or {}).get("reason", "refused"))
            self.object_received.emit(first)  # the protocol's own refusal: the UI shows it
            self._fail(f"the station refused this tablet: {reason}", shown=True)
            return
        body = first.get("paired") or first.get("authorised")
        if not isinstance(body, dict) or not isinstance(body.get("tablet_id"), str):
            self._fail("the station did not answer pair/auth (is it an Interbot station?)")
            return
        if "paired" in first:
            token = body.get("token")
            if not isinstance(token, str):
                self._fail("the station's pairing answer has no token")
                return
            fields = (self._host, self._port, self.fingerprint, token, body["tablet_id"])
            try:  # the station's answer is outside input too: the declared types check it
                creds = schema.convert(
                    dict(zip(TabletCredentials.__struct_fields__, fields, strict=True)),
                    TabletCredentials,
                    "pairing answer",
                )
            except ValueError as exc:
                self._fail(f"the station's pairing answer is invalid: {exc}")
                return
            self._token, self._code = token, None
            logger.info("paired with the station as %s", creds.tablet_id)
            self.paired.emit(creds)
        self._authorised = True
        self.connected.emit()
        for item in rest:
            if isinstance(item, ProtocolError):
                self.frame_error.emit(item)
            else:
                self.object_received.emit(item)

    def _fail(self, reason: str, *, shown: bool = False) -> None:
        """Drop the connection; the reason reaches the screen as a refusal (never silent)."""
        logger.warning("%s", reason)
        if not shown:
            self.object_received.emit({"refused": {"reason": f"not connected: {reason}"}})
        self.auth_failed.emit(reason)
        self.socket_error.emit(reason)
        if self._ssl.state() != QAbstractSocket.SocketState.UnconnectedState:
            self._ssl.abort()
