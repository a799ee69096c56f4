"""`interbot router` refuses to listen off this machine without keys, and says how to fix it."""

from __future__ import annotations

from pathlib import Path

import pytest

from interbot_cli.main import main


def test_router_off_loopback_needs_keys(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["router", "--listen", "tcp/0.0.0.0:7447"]) == 2
    assert "interbot keys init" in capsys.readouterr().err


def test_router_with_keys_needs_a_router_certificate(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    keys = tmp_path / "keys"
    assert main(["keys", "init", str(keys)]) == 0
    assert main(["router", "--security", str(keys), "--listen", "tls/127.0.0.1:1"]) == 2
    assert "add-router router" in capsys.readouterr().err
    assert main(["keys", "add-router", "router", "--dir", str(keys)]) == 0
