"""Pairing codes and per-tablet tokens (pure; deterministic random bytes, injected time)."""

from __future__ import annotations

import itertools

import pytest

from interbot_core.tablet_pairing import (
    PairingError,
    PairingOffer,
    TabletRegistry,
    auth_frame,
    decode_auth_frame,
    hash_token,
    pair_frame,
    parse_pairing_uri,
)

FP = "ab" * 32


def counter_bytes():  # deterministic, distinct outputs
    counter = itertools.count(1)
    return lambda n: next(counter).to_bytes(n, "big")


def test_a_code_pairs_once_and_the_token_authenticates() -> None:
    reg = TabletRegistry(counter_bytes())
    code, expires = reg.new_code(now=10.0)
    assert len(code) == 6 and code.isdigit() and expires == 10.0 + reg.code_ttl
    record, token = reg.pair(code, "lobby", now=20.0)
    assert record.tablet_id == "t1" and record.token_sha256 == hash_token(token)
    assert token not in str(reg.to_json())  # the station keeps only the digest
    assert reg.authenticate(token) == record
    with pytest.raises(PairingError, match="no pairing code"):
        reg.pair(code, "again", now=21.0)


def test_expired_wrong_and_guessed_codes_are_refused() -> None:
    reg = TabletRegistry(counter_bytes(), max_attempts=3)
    code, _ = reg.new_code(now=0.0)
    with pytest.raises(PairingError, match="expired"):
        reg.pair(code, "late", now=reg.code_ttl + 1.0)
    code, _ = reg.new_code(now=0.0)
    wrong = f"{(int(code) + 1) % 10**6:06d}"
    for _ in range(2):
        with pytest.raises(PairingError, match=r"wrong pairing code$"):
            reg.pair(wrong, "guess", now=1.0)
    with pytest.raises(PairingError, match="too many attempts"):
        reg.pair(wrong, "guess", now=1.0)
    with pytest.raises(PairingError, match="no pairing code"):
        reg.pair(code, "right but too late", now=1.0)
    assert reg.records == ()


def test_revoked_and_unknown_tokens_are_refused_and_persisted() -> None:
    reg = TabletRegistry(counter_bytes())
    record, token = reg.pair(reg.new_code(0.0)[0], "lobby", 1.0)
    reg.revoke(record.tablet_id)
    with pytest.raises(PairingError, match="revoked"):
        reg.authenticate(token)
    with pytest.raises(PairingError, match="unknown tablet token"):
        reg.authenticate("0" * 64)
    again = TabletRegistry.from_json(reg.to_json(), counter_bytes())
    assert again.records == reg.records
    with pytest.raises(PairingError, match="revoked"):
        again.authenticate(token)
    with pytest.raises(PairingError, match="no tablet"):
        reg.revoke("t9")


@pytest.mark.parametrize(
    "frame",
    [{"hello": {"protocol": 1}}, {"speed": {}}, [], {"pair": {"code": 1}},
     {"auth": {"token": "short"}}, {"pair": {}, "auth": {}}],
)  # fmt: skip
def test_anything_but_pair_or_auth_first_is_refused(frame: object) -> None:
    with pytest.raises(PairingError):
        decode_auth_frame(frame)


def test_auth_frames_round_trip() -> None:
    assert decode_auth_frame(pair_frame("123456", "lobby")).kind == "pair"
    req = decode_auth_frame(auth_frame("a" * 64))
    assert (req.kind, req.secret) == ("auth", "a" * 64)


def test_pairing_uri_round_trips_and_rejects_garbage() -> None:
    offer = PairingOffer("192.0.2.7", 5555, FP, "012345", 0.0)
    target = parse_pairing_uri(offer.uri)
    assert (target.host, target.port, target.fingerprint, target.code) == (
        "192.0.2.7", 5555, FP, "012345"
    )  # fmt: skip
    for bad in ("http://x:1?fp=&code=1", offer.uri.replace("code=012345", "code=12"),
                offer.uri.replace(FP, "xyz")):  # fmt: skip
        with pytest.raises(PairingError):
            parse_pairing_uri(bad)


@pytest.mark.parametrize(
    ("entry", "message"),
    [
        ({"revoked": "no"}, r"tablets\[0\]\.revoked must be true or false, got 'no'"),
        ({"token_sha256": "00"}, r"tablets\[0\]\.token_sha256 must be a string matching"),
        ({"paired_at": "today"}, r"tablets\[0\]\.paired_at must be a number"),
        ({"name": ""}, r"tablets\[0\]\.name must be a string matching"),
    ],
)
def test_registry_file_with_wrong_types_is_refused(entry: dict[str, object], message: str) -> None:
    """The registry file is outside input: a string where a flag belongs ("no" is truthy) must
    not load as a revoked (or trusted) tablet."""
    good = {"tablet_id": "t1", "name": "lobby", "token_sha256": "a" * 64, "paired_at": 5.0}
    with pytest.raises(PairingError, match=message):
        TabletRegistry.from_json({"version": 1, "tablets": [{**good, **entry}]}, counter_bytes())
    assert TabletRegistry.from_json({"version": 1, "tablets": [good]}, counter_bytes()).records
