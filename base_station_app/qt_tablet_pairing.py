"""Pairing and revoking tablets in the Tablet tab (issue 15; docs/security.md).

"Pair a tablet" asks `TabletAuthServer` for a one-time code and shows it large, with its expiry
and a QR code of the pairing address (host, port, certificate fingerprint, code) drawn with
``segno``; the tablet scans or types it once (``interbot-tablet --pair URI``). The list shows the
paired tablets; "Revoke" refuses the selected one from then on and drops it if connected.
"""

from __future__ import annotations

import io
import logging
import time

import segno
from PySide6.QtCore import Qt, QTimer
from PySide6.QtGui import QFont, QPixmap
from PySide6.QtWidgets import (
    QGroupBox,
    QLabel,
    QListWidget,
    QListWidgetItem,
    QVBoxLayout,
    QWidget,
)

from base_station_app.tablet_auth import TabletAuthServer
from interbot_qt.layout import button, row

logger = logging.getLogger(__name__)


def qr_pixmap(text: str, scale: int = 4) -> QPixmap:
    """A QR code of ``text`` as a pixmap (segno writes a PNG; Qt reads it)."""
    buffer = io.BytesIO()
    segno.make(text, error="m").save(buffer, kind="png", scale=scale, border=2)
    pixmap = QPixmap()
    pixmap.loadFromData(buffer.getvalue(), "PNG")
    return pixmap


class QtTabletPairing(QGroupBox):
    """Pairing code + QR code, the paired tablets and their revocation."""

    def __init__(self, auth: TabletAuthServer, parent: QWidget | None = None) -> None:
        super().__init__("Tablet pairing (TLS)", parent)
        self._auth = auth
        layout = QVBoxLayout(self)
        self.fingerprint_label = QLabel(f"station certificate SHA-256: {auth.fingerprint[:32]}…")
        self.fingerprint_label.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        layout.addWidget(self.fingerprint_label)
        self.pair_button = button("Pair a tablet", self.show_code)
        self.code_label = QLabel("")
        font = QFont(self.code_label.font())
        font.setPointSize(font.pointSize() * 2)
        font.setBold(True)
        self.code_label.setFont(font)
        layout.addLayout(row(self.pair_button, (self.code_label, 1)))
        self.qr_label = QLabel()
        self.uri_label = QLabel()
        self.uri_label.setWordWrap(True)
        self.uri_label.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        layout.addWidget(self.qr_label, 0, Qt.AlignmentFlag.AlignHCenter)
        layout.addWidget(self.uri_label)
        self.tablets = QListWidget()
        self.tablets.setMaximumHeight(110)
        layout.addWidget(self.tablets)
        self.revoke_button = button("Revoke selected tablet", self.revoke_selected)
        layout.addWidget(self.revoke_button)
        auth.tablets_changed.connect(self.refresh)
        self._expiry = QTimer(self)  # an expired or used code disappears from the screen
        self._expiry.setInterval(1000)
        self._expiry.timeout.connect(self._check_expiry)
        self.refresh()

    def show_code(self) -> None:
        offer = self._auth.new_offer()
        minutes = max(0.0, offer.expires - time.time()) / 60.0
        self.code_label.setText(
            f"{offer.code[:3]} {offer.code[3:]}  (valid {minutes:.0f} min, once)"
        )
        self.qr_label.setPixmap(qr_pixmap(offer.uri))
        self.uri_label.setText(f"interbot-tablet --pair '{offer.uri}'")
        self._expiry.start()

    def _check_expiry(self) -> None:
        offer = self._auth.offer
        if offer is None or not self._auth.registry.code_active(self._auth.clock()):
            self._auth.offer = None
            self._expiry.stop()
            self.refresh()

    def refresh(self) -> None:
        if self._auth.offer is None:
            self.code_label.setText("")
            self.qr_label.clear()
            self.uri_label.setText("")
        self.tablets.clear()
        for record in self._auth.registry.records:
            state = "REVOKED" if record.revoked else "paired"
            when = time.strftime("%Y-%m-%d %H:%M", time.localtime(record.paired_at))
            item = QListWidgetItem(f"{record.tablet_id}  {record.name}  ({state} {when})")
            item.setData(Qt.ItemDataRole.UserRole, record.tablet_id)
            if record.revoked:
                item.setFlags(item.flags() & ~Qt.ItemFlag.ItemIsSelectable)
            self.tablets.addItem(item)
        self.revoke_button.setEnabled(self.tablets.count() > 0)

    def revoke_selected(self) -> None:
        item = self.tablets.currentItem()
        if item is None or not item.isSelected():
            return
        self._auth.revoke(str(item.data(Qt.ItemDataRole.UserRole)))
