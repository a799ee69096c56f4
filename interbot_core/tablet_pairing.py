"""Tablet pairing and per-tablet tokens: who may act as the tablet (issue 15; docs/security.md).

The tablet link is TLS with the station's certificate pinned on the tablet by its SHA-256
digest. Before the thesis's JSON protocol starts, the tablet proves who it is with ONE frame:

* ``{"pair": {"code": "123456", "name": "tablet-lobby"}}`` the first time: the operator pressed
  "Pair a tablet" at the station, which shows a short one-time code (and a QR code of
  `PairingOffer.uri`: host, port, fingerprint, code). A code is valid for ``code_ttl`` seconds,
  once, and dies after ``max_attempts`` wrong guesses (10^6 codes, 5 guesses: 5 in a million).
  The station answers ``{"paired": {"tablet_id": "t1", "token": "..."}}``: a long-lived random
  token (256 bits) the tablet keeps; the station keeps only its SHA-256.
* ``{"auth": {"token": "..."}}`` afterwards; answered ``{"authorised": {"tablet_id": "t1"}}``.

Anything else, a wrong code, an unknown or revoked token, is answered
``{"refused": {"reason": ...}}`` (the protocol's own refusal, which a thesis-era tablet shows)
and the connection is closed before any message is acted on. The operator revokes a tablet in
the Tablet tab; its token is then refused.

Pure: time comes in as ``now`` [s], randomness from an injected ``random_bytes`` (the station
passes `secrets.token_bytes`: tokens and codes must be unpredictable, so not a seeded
generator); the caller stores `TabletRegistry.to_json` wherever it likes.
"""

from __future__ import annotations

import hashlib
import hmac
import logging
import re
import urllib.parse
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Annotated, Any, ClassVar, Final, Literal

import msgspec
from msgspec import Meta

from interbot_core import schema
from interbot_core.schema import SchemaError

logger = logging.getLogger(__name__)

CODE_DIGITS: Final = 6
CODE_TTL: Final = 300.0  # [s]
MAX_ATTEMPTS: Final = 5
TOKEN_BYTES: Final = 32
URI_SCHEME: Final = "interbot-pair"
AUTH_KEYS: Final = ("pair", "auth")
_FINGERPRINT = re.compile(r"[0-9a-f]{64}")
_TOKEN = re.compile(r"[0-9a-f]{64}")
_NAME = re.compile(r"[\w .@-]{1,64}")


class PairingError(ValueError):
    """A pairing or authentication attempt is refused; the message is sent to the tablet."""


class TabletRecord(schema.Declared, frozen=True):
    """A paired tablet as the station remembers it (the token only as its SHA-256)."""

    ROOT: ClassVar[str] = "tablet"
    ERROR: ClassVar[type[Exception]] = PairingError
    tablet_id: Annotated[str, Meta(pattern=r"^t\d{1,9}$")]
    name: Annotated[str, Meta(pattern=r"^[\w .@-]{1,64}$")]
    token_sha256: Annotated[str, Meta(pattern=r"^[0-9a-f]{64}$")]
    paired_at: schema.Finite  # [s] the caller's clock (wall time when persisted)
    revoked: bool = False


class RegistryFile(msgspec.Struct, frozen=True):
    """The station's tablet registry file: ``{"version": 1, "tablets": [record, ...]}``."""

    version: Literal[1]
    tablets: list[TabletRecord] = []


@dataclass(frozen=True)
class PairingOffer:
    """What the station shows: the one-time code and where/whom to connect to."""

    host: str
    port: int
    fingerprint: str  # hex SHA-256 of the station's certificate
    code: str
    expires: float  # [s] on the caller's clock

    @property
    def uri(self) -> str:
        """``interbot-pair://HOST:PORT?fp=...&code=...`` (the QR code's text)."""
        query = urllib.parse.urlencode({"fp": self.fingerprint, "code": self.code})
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"{URI_SCHEME}://{host}:{self.port}?{query}"


@dataclass(frozen=True)
class PairingTarget:
    """A parsed pairing URI (what the tablet needs to pair)."""

    host: str
    port: int
    fingerprint: str
    code: str


def normalise_fingerprint(text: str) -> str:
    """Lower-case hex without colons; raise PairingError unless it is a SHA-256 digest."""
    fp = str(text).replace(":", "").strip().lower()
    if _FINGERPRINT.fullmatch(fp) is None:
        raise PairingError(f"fingerprint {text!r} is not a SHA-256 digest (64 hex digits)")
    return fp


def parse_pairing_uri(uri: str) -> PairingTarget:
    """Parse `PairingOffer.uri`; raise PairingError naming what is wrong."""
    parsed = urllib.parse.urlsplit(str(uri).strip())
    if parsed.scheme != URI_SCHEME:
        raise PairingError(f"{uri!r} is not an {URI_SCHEME}:// address")
    try:
        port = parsed.port
    except ValueError:
        port = None
    if not parsed.hostname or port is None or not 0 < port < 65536:
        raise PairingError(f"{uri!r} has no valid host:port")
    query = urllib.parse.parse_qs(parsed.query)
    code = (query.get("code") or [""])[0]
    if not re.fullmatch(rf"[0-9]{{{CODE_DIGITS}}}", code):
        raise PairingError(f"{uri!r} has no {CODE_DIGITS}-digit code")
    fp = normalise_fingerprint((query.get("fp") or [""])[0])
    return PairingTarget(parsed.hostname, port, fp, code)


def hash_token(token: str) -> str:
    return hashlib.sha256(token.encode("ascii")).hexdigest()


# --------------------------------------------------------------------------- auth frames


def pair_frame(code: str, name: str) -> dict[str, Any]:
    return {"pair": {"code": code, "name": name}}


def auth_frame(token: str) -> dict[str, Any]:
    return {"auth": {"token": token}}


@dataclass(frozen=True)
class AuthRequest:
    """A decoded first frame: ``pair`` (code + name) or ``auth`` (token)."""

    kind: str
    secret: str  # the code or the token
    name: str = ""


def decode_auth_frame(obj: object) -> AuthRequest:
    """Validate the tablet's first frame; PairingError (to be sent back) otherwise."""
    if not isinstance(obj, Mapping) or len(obj) != 1:
        raise PairingError(
            "this station requires a paired tablet: the first message must be pair or auth "
            "(pair the tablet at the station's Tablet tab)"
        )
    (kind, body), = obj.items()  # fmt: skip
    if kind not in AUTH_KEYS or not isinstance(body, Mapping):
        raise PairingError(
            f"this station requires a paired tablet: got {str(kind)[:32]!r} before pairing "
            "(pair the tablet at the station's Tablet tab)"
        )
    if kind == "pair":
        code, name = body.get("code"), body.get("name", "tablet")
        if not isinstance(code, str) or not isinstance(name, str) or not _NAME.fullmatch(name):
            raise PairingError("pair needs a code and a name of 1-64 letters, digits, ' .@-_'")
        return AuthRequest("pair", code, name)
    token = body.get("token")
    if not isinstance(token, str) or _TOKEN.fullmatch(token) is None:
        raise PairingError("auth needs the token this station gave at pairing")
    return AuthRequest("auth", token)


# --------------------------------------------------------------------------- the registry


class TabletRegistry:
    """Paired tablets and the current one-time code of one station."""

    def __init__(
        self,
        random_bytes: Callable[[int], bytes],
        records: tuple[TabletRecord, ...] = (),
        *,
        code_ttl: float = CODE_TTL,
        max_attempts: int = MAX_ATTEMPTS,
    ) -> None:
        self._random = random_bytes
        self._records = {r.tablet_id: r for r in records}
        self._code: str | None = None
        self._code_expires = 0.0
        self._attempts = 0
        self.code_ttl = code_ttl
        self.max_attempts = max_attempts

    @property
    def records(self) -> tuple[TabletRecord, ...]:
        return tuple(self._records.values())

    def new_code(self, now: float) -> tuple[str, float]:
        """A fresh one-time code (replaces any previous one) and its expiry time [s]."""
        value = int.from_bytes(self._random(8), "big") % 10**CODE_DIGITS
        self._code = f"{value:0{CODE_DIGITS}d}"
        self._code_expires = now + self.code_ttl
        self._attempts = 0
        logger.info("new tablet pairing code, valid %.0f s", self.code_ttl)
        return self._code, self._code_expires

    def code_active(self, now: float) -> bool:
        return self._code is not None and now <= self._code_expires

    def pair(self, code: str, name: str, now: float) -> tuple[TabletRecord, str]:
        """Check the one-time code; on success issue a token (returned once) and a record."""
        if self._code is None:
            raise PairingError("no pairing code is active: press 'Pair a tablet' at the station")
        if now > self._code_expires:
            self._code = None
            raise PairingError("the pairing code has expired: press 'Pair a tablet' again")
        if not hmac.compare_digest(code.encode(), self._code.encode()):
            self._attempts += 1
            if self._attempts >= self.max_attempts:
                self._code = None
                raise PairingError("wrong pairing code; too many attempts, the code is void")
            raise PairingError("wrong pairing code")
        self._code = None  # one use
        token = self._random(TOKEN_BYTES).hex()
        number = 1 + max((int(t[1:]) for t in self._records if t[1:].isdigit()), default=0)
        record = TabletRecord(f"t{number}", name, hash_token(token), now)
        self._records[record.tablet_id] = record
        logger.info("paired tablet %s (%s)", record.tablet_id, name)
        return record, token

    def authenticate(self, token: str) -> TabletRecord:
        """The record whose token this is; PairingError if unknown or revoked."""
        digest = hash_token(token)
        for record in self._records.values():
            if hmac.compare_digest(digest, record.token_sha256):
                if record.revoked:
                    raise PairingError(
                        f"tablet {record.tablet_id} ({record.name}) was revoked at the station; "
                        "pair it again"
                    )
                return record
        raise PairingError("unknown tablet token: pair this tablet at the station's Tablet tab")

    def revoke(self, tablet_id: str) -> TabletRecord:
        record = self._records.get(tablet_id)
        if record is None:
            raise PairingError(f"no tablet {tablet_id!r} (paired: {sorted(self._records)})")
        record = msgspec.structs.replace(record, revoked=True)
        self._records[tablet_id] = record
        logger.warning("revoked tablet %s (%s)", tablet_id, record.name)
        return record

    # ------------------------------------------------------------------ persistence

    def to_json(self) -> dict[str, Any]:
        tablets = [msgspec.structs.asdict(r) for r in self._records.values()]
        return {"version": 1, "tablets": tablets}

    @classmethod
    def from_json(cls, data: object, random_bytes: Callable[[int], bytes]) -> TabletRegistry:
        """Rebuild from `to_json`; PairingError naming the bad entry otherwise."""
        try:
            registry = schema.convert(data, RegistryFile, "tablet registry")
        except SchemaError as exc:
            raise PairingError(exc.message) from None
        return cls(random_bytes, tuple(registry.tablets))
