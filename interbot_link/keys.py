"""Interbot's small certificate authority: the keys behind mutual TLS and access control.

One directory holds everything (``interbot keys init DIR``)::

    ca.crt  ca.key                 the Interbot CA (keep ca.key on the operator's machine only)
    <name>.crt  <name>.key         one certificate per robot, station and observer
    interbot-keys.yaml             the inventory: name -> role, serial, SHA-256, revoked

Every member's certificate carries its name as the subject common name (CN) and its role as the
organisational unit; zenoh's access control (`interbot_link.security`) names subjects by CN, so
the name is the identity. Keys are ECDSA P-256 (PKCS#8 PEM, mode 0600), certificates X.509 v3
signed by the CA, with the name, ``localhost``, 127.0.0.1 and ::1 (and any ``hosts`` given) as
subject alternative names. Revoking a member marks it in the inventory: the access-control
rules built from the inventory no longer name it, so its still-valid certificate opens a TLS
link that can do nothing (zenoh 1.x has no CRL support); restart the robots and stations after
revoking. Made with the PyCA ``cryptography`` package, no openssl binary.

Time is injected (``now``, a timezone-aware datetime) so expiry is testable.
"""

from __future__ import annotations

import datetime as dt
import ipaddress
import logging
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Final

import msgspec
import yaml
from cryptography import x509
from cryptography.exceptions import InvalidSignature
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID
from msgspec import Meta

from interbot_core import schema

logger = logging.getLogger(__name__)

ROLES: Final = ("robot", "station", "observer", "router")
NAME_PATTERN: Final = re.compile(r"[A-Za-z0-9_-]{1,32}")
INVENTORY: Final = "interbot-keys.yaml"
CA_NAME: Final = "ca"
CA_DAYS: Final = 3650
LEAF_DAYS: Final = 825
DEFAULT_MEMBERS: Final = (("interbot1", "robot"), ("station", "station"), ("observer", "observer"))
SETUP_HINT: Final = (
    "create keys with `interbot keys init DIR` (a CA and certificates for robot interbot1, "
    "station and observer; more with `interbot keys add-robot NAME --dir DIR`), then start "
    "with `--security DIR`; see docs/security.md"
)


class KeysError(Exception):
    """The key directory or a certificate is missing, malformed, expired or revoked."""


class Member(msgspec.Struct, frozen=True, forbid_unknown_fields=True):
    """One certificate holder in the inventory (each entry of the file is checked by these types)."""

    name: str
    role: Annotated[str, schema.one_of(*ROLES)]
    serial: Annotated[int, Meta(ge=0)]
    sha256: Annotated[str, Meta(pattern=r"^[0-9a-f]{64}$")]  # hex digest of the DER certificate
    not_after: str  # ISO 8601, UTC
    revoked: bool = False


@dataclass(frozen=True)
class Identity:
    """A validated member with the paths of its certificate, key and the CA certificate."""

    name: str
    role: str
    ca_cert: Path
    cert: Path
    key: Path
    sha256: str


def utcnow() -> dt.datetime:
    return dt.datetime.now(dt.UTC)


def validate_name(name: str) -> str:
    if not isinstance(name, str) or NAME_PATTERN.fullmatch(name) is None or name == CA_NAME:
        raise KeysError(
            f"name {name!r} is invalid: use 1-32 characters from A-Z a-z 0-9 _ - (not 'ca')"
        )
    return name


def cert_sha256(cert: x509.Certificate) -> str:
    """Hex SHA-256 of the DER certificate (what the tablet pins; Qt's digest(Sha256))."""
    return cert.fingerprint(hashes.SHA256()).hex()


def load_cert(path: Path) -> x509.Certificate:
    try:
        return x509.load_pem_x509_certificate(path.read_bytes())
    except OSError as exc:
        raise KeysError(f"cannot read certificate {path}: {exc.strerror}") from None
    except ValueError as exc:
        raise KeysError(f"{path} is not a PEM certificate: {exc}") from None


def _load_key(path: Path) -> ec.EllipticCurvePrivateKey:
    try:
        key = serialization.load_pem_private_key(path.read_bytes(), password=None)
    except OSError as exc:
        raise KeysError(f"cannot read private key {path}: {exc.strerror}") from None
    except (ValueError, TypeError) as exc:
        raise KeysError(f"{path} is not an unencrypted PEM private key: {exc}") from None
    if not isinstance(key, ec.EllipticCurvePrivateKey):
        raise KeysError(f"{path}: expected an EC private key")
    return key


def _write(path: Path, data: bytes, private: bool) -> None:
    if private:
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.chmod(path, 0o600)
    else:
        path.write_bytes(data)


def _key_pem(key: ec.EllipticCurvePrivateKey) -> bytes:
    return key.private_bytes(
        serialization.Encoding.PEM,
        serialization.PrivateFormat.PKCS8,
        serialization.NoEncryption(),
    )


class KeyStore:
    """A key directory: its CA, its members, and their validation."""

    def __init__(self, directory: str | Path) -> None:
        self.dir = Path(directory).expanduser()
        inventory = self.dir / INVENTORY
        if not inventory.is_file():
            raise KeysError(
                f"{self.dir} is not an Interbot key directory (no {INVENTORY}); {SETUP_HINT}"
            )
        raw = schema.read_yaml(inventory, KeysError, "key inventory")
        if not isinstance(raw, dict) or not isinstance(raw.get("members"), dict):
            raise KeysError(f"{inventory}: expected a mapping with 'members'")
        self.members: dict[str, Member] = {}
        for name, entry in raw["members"].items():
            try:
                validate_name(str(name))
                fields = {**entry, "name": str(name)} if isinstance(entry, dict) else entry
                self.members[str(name)] = schema.convert(fields, Member, f"members.{name}")
            except (ValueError, KeysError) as exc:
                raise KeysError(f"{inventory}: member {name!r} is malformed: {exc}") from None
        self.ca_cert_path = self.dir / f"{CA_NAME}.crt"
        self.ca_cert = load_cert(self.ca_cert_path)

    # ------------------------------------------------------------------ creation

    @classmethod
    def init(
        cls,
        directory: str | Path,
        members: tuple[tuple[str, str], ...] = DEFAULT_MEMBERS,
        *,
        now: dt.datetime | None = None,
        ca_days: int = CA_DAYS,
        days: int = LEAF_DAYS,
    ) -> KeyStore:
        """Create a CA in ``directory`` (new or empty) and a certificate per (name, role)."""
        path = Path(directory).expanduser()
        if (path / INVENTORY).exists() or (path / f"{CA_NAME}.key").exists():
            raise KeysError(f"{path} already holds Interbot keys; add members with add-robot etc.")
        if path.exists() and (not path.is_dir() or any(path.iterdir())):
            raise KeysError(f"{path} is not a new or empty directory; choose another for the keys")
        now = now or utcnow()
        path.mkdir(parents=True, exist_ok=True)
        os.chmod(path, 0o700)
        ca_key = ec.generate_private_key(ec.SECP256R1())
        ca_name = x509.Name(
            [
                x509.NameAttribute(NameOID.ORGANIZATION_NAME, "Interbot"),
                x509.NameAttribute(NameOID.COMMON_NAME, "Interbot CA"),
            ]
        )
        ca = (
            x509.CertificateBuilder()
            .subject_name(ca_name)
            .issuer_name(ca_name)
            .public_key(ca_key.public_key())
            .serial_number(x509.random_serial_number())
            .not_valid_before(now - dt.timedelta(minutes=5))
            .not_valid_after(now + dt.timedelta(days=ca_days))
            .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
            .add_extension(
                x509.KeyUsage(
                    digital_signature=False,
                    content_commitment=False,
                    key_encipherment=False,
                    data_encipherment=False,
                    key_agreement=False,
                    key_cert_sign=True,
                    crl_sign=True,
                    encipher_only=False,
                    decipher_only=False,
                ),
                critical=True,
            )
            .add_extension(
                x509.SubjectKeyIdentifier.from_public_key(ca_key.public_key()), critical=False
            )
            .sign(ca_key, hashes.SHA256())
        )
        _write(path / f"{CA_NAME}.key", _key_pem(ca_key), private=True)
        _write(path / f"{CA_NAME}.crt", ca.public_bytes(serialization.Encoding.PEM), False)
        _write(path / INVENTORY, b"members: {}\n", private=False)
        store = cls(path)
        for name, role in members:
            store.add(name, role, now=now, days=days)
        logger.info("created Interbot keys in %s", path)
        return store

    def add(
        self,
        name: str,
        role: str,
        hosts: tuple[str, ...] = (),
        *,
        now: dt.datetime | None = None,
        days: int = LEAF_DAYS,
    ) -> Member:
        """Issue a certificate for a new member (names are unique across roles)."""
        validate_name(name)
        if role not in ROLES:
            raise KeysError(f"role {role!r} is unknown; use one of {list(ROLES)}")
        if name in self.members:
            raise KeysError(
                f"{name!r} already exists ({self.members[name].role}); choose another name"
            )
        if not 1 <= days <= 36500:
            raise KeysError(f"days must be in 1..36500, got {days}")
        ca_key_path = self.dir / f"{CA_NAME}.key"
        if not ca_key_path.is_file():
            raise KeysError(
                f"{ca_key_path} is missing: issue certificates where the CA key is kept"
            )
        ca_key = _load_key(ca_key_path)
        now = now or utcnow()
        key = ec.generate_private_key(ec.SECP256R1())
        alt_names: list[x509.GeneralName] = [x509.DNSName(name), x509.DNSName("localhost")]
        alt_names += [x509.IPAddress(ipaddress.ip_address(a)) for a in ("127.0.0.1", "::1")]
        for host in hosts:
            try:
                alt_names.append(x509.IPAddress(ipaddress.ip_address(host)))
            except ValueError:
                if not re.fullmatch(r"[A-Za-z0-9.-]{1,253}", host):
                    raise KeysError(
                        f"host {host!r} is neither an IP address nor a DNS name"
                    ) from None
                alt_names.append(x509.DNSName(host))
        not_after = now + dt.timedelta(days=days)
        cert = (
            x509.CertificateBuilder()
            .subject_name(
                x509.Name(
                    [
                        x509.NameAttribute(NameOID.ORGANIZATION_NAME, "Interbot"),
                        x509.NameAttribute(NameOID.ORGANIZATIONAL_UNIT_NAME, role),
                        x509.NameAttribute(NameOID.COMMON_NAME, name),
                    ]
                )
            )
            .issuer_name(self.ca_cert.subject)
            .public_key(key.public_key())
            .serial_number(x509.random_serial_number())
            .not_valid_before(now - dt.timedelta(minutes=5))
            .not_valid_after(not_after)
            .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
            .add_extension(x509.SubjectAlternativeName(alt_names), critical=False)
            .add_extension(
                x509.ExtendedKeyUsage(
                    [ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH]
                ),
                critical=False,
            )
            .add_extension(
                x509.AuthorityKeyIdentifier.from_issuer_public_key(ca_key.public_key()),
                critical=False,
            )
            .sign(ca_key, hashes.SHA256())
        )
        _write(self.dir / f"{name}.key", _key_pem(key), private=True)
        _write(self.dir / f"{name}.crt", cert.public_bytes(serialization.Encoding.PEM), False)
        member = Member(
            name=name,
            role=role,
            serial=cert.serial_number,
            sha256=cert_sha256(cert),
            not_after=not_after.replace(microsecond=0).isoformat(),
        )
        self.members[name] = member
        self._save()
        logger.info("issued %r a %s certificate (until %s)", name, role, member.not_after)
        return member

    def revoke(self, name: str) -> Member:
        """Mark ``name`` revoked: the access-control rules built from here no longer name it."""
        member = self.members.get(name)
        if member is None:
            raise KeysError(f"no member {name!r} in {self.dir} (members: {sorted(self.members)})")
        revoked = msgspec.structs.replace(member, revoked=True)
        self.members[name] = revoked
        self._save()
        logger.warning("revoked %s %r (restart robots and stations to apply)", member.role, name)
        return revoked

    def _save(self) -> None:
        members = {
            n: {k: v for k, v in msgspec.structs.asdict(m).items() if k != "name"}
            for n, m in sorted(self.members.items())
        }
        data: dict[str, Any] = {"members": members}
        tmp = self.dir / f".{INVENTORY}.tmp"
        tmp.write_text(yaml.safe_dump(data, sort_keys=True), encoding="utf-8")
        tmp.replace(self.dir / INVENTORY)

    def export(self, name: str, target: str | Path) -> Path:
        """Copy what member ``name``'s machine needs (never ``ca.key``) into ``target``.

        That is the CA certificate, its own certificate and key, and the inventory (the access
        control rules are built from it); other members' keys stay here.
        """
        self.identity(name)  # present, not revoked, valid
        out = Path(target).expanduser()
        if (out / INVENTORY).exists() and out.resolve() == self.dir.resolve():
            raise KeysError("export to another directory than the key directory itself")
        out.mkdir(parents=True, exist_ok=True)
        os.chmod(out, 0o700)
        for file, private in (
            (f"{CA_NAME}.crt", False),
            (f"{name}.crt", False),
            (f"{name}.key", True),
            (INVENTORY, False),
        ):
            _write(out / file, (self.dir / file).read_bytes(), private)
        logger.info("exported %r to %s (without the CA key)", name, out)
        return out

    # ------------------------------------------------------------------ use

    def names(self, role: str, *, now: dt.datetime | None = None) -> tuple[str, ...]:
        """Names of the members of ``role`` that are neither revoked nor expired, sorted."""
        now = now or utcnow()
        return tuple(
            sorted(
                n
                for n, m in self.members.items()
                if m.role == role and not m.revoked and dt.datetime.fromisoformat(m.not_after) > now
            )
        )

    def identity(
        self, name: str, role: str | None = None, *, now: dt.datetime | None = None
    ) -> Identity:
        """Load and check ``name``'s certificate and key; raise KeysError saying what is wrong.

        Checked: present in the inventory, not revoked, of ``role``; the certificate is signed
        by this CA, currently valid (not expired, not yet valid) and matches its private key.
        """
        member = self.members.get(name)
        if member is None:
            known = ", ".join(f"{n} ({m.role})" for n, m in sorted(self.members.items()))
            raise KeysError(
                f"no certificate for {name!r} in {self.dir} (members: {known or 'none'}); "
                f"issue one with `interbot keys add-{role or 'robot'} {name} --dir {self.dir}`"
            )
        if member.revoked:
            raise KeysError(f"the certificate of {name!r} in {self.dir} is revoked")
        if role is not None and member.role != role:
            raise KeysError(f"{name!r} in {self.dir} is a {member.role}, not a {role}")
        cert_path, key_path = self.dir / f"{name}.crt", self.dir / f"{name}.key"
        cert = load_cert(cert_path)
        check_certificate(cert, self.ca_cert, str(cert_path), now=now)
        key = _load_key(key_path)
        if key_path.stat().st_mode & 0o077:
            logger.warning(
                "%s is readable by other users (mode %o): chmod 600 it",
                key_path,
                key_path.stat().st_mode & 0o777,
            )
        if key.public_key().public_numbers() != cert.public_key().public_numbers():  # type: ignore[union-attr]
            raise KeysError(f"{key_path} is not the private key of {cert_path}")
        if cert_sha256(cert) != member.sha256:
            raise KeysError(f"{cert_path} is not the certificate recorded in {INVENTORY}")
        return Identity(name, member.role, self.ca_cert_path, cert_path, key_path, member.sha256)


def check_certificate(
    cert: x509.Certificate,
    ca: x509.Certificate,
    what: str,
    *,
    now: dt.datetime | None = None,
) -> None:
    """Raise KeysError unless ``cert`` is issued by ``ca`` and valid at ``now``."""
    now = now or utcnow()
    try:
        cert.verify_directly_issued_by(ca)
    except (ValueError, TypeError, InvalidSignature):
        raise KeysError(
            f"{what} was not issued by this Interbot CA ({ca.subject.rfc4514_string()}); "
            "use certificates from the same `interbot keys init` directory on every machine"
        ) from None
    for c, label in ((ca, "the CA certificate"), (cert, what)):
        if now < c.not_valid_before_utc:
            raise KeysError(
                f"{label} is not valid before {c.not_valid_before_utc:%Y-%m-%d %H:%M} UTC "
                "(is this machine's clock right?)"
            )
        if now > c.not_valid_after_utc:
            raise KeysError(
                f"{label} expired on {c.not_valid_after_utc:%Y-%m-%d %H:%M} UTC; issue a new "
                "one (`interbot keys revoke NAME`, then `interbot keys add-... NEWNAME`)"
            )
