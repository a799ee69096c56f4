"""``interbot-base-station`` as a process: starts offscreen against a robot, serves a tablet,
and exits cleanly (zenoh session closed from aboutToQuit) on SIGTERM."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time

import pytest
import zenoh

from base_station_app.main import build_parser, main
from interbot_link import RobotLink, session_config
from tests.ports import reserve_port


def free_port() -> int:
    """Held for the subprocess that listens on it seconds later (tests/ports.py)."""
    return reserve_port()


def test_parser_defaults():
    args = build_parser().parse_args([])
    assert args.connect is None and args.tablet_port == 5555 and args.tablet_host == "127.0.0.1"
    assert str(args.topo).endswith("maps/isr_floor0_topo.yaml")
    assert args.topo.is_absolute() and args.topo.is_file()  # not relative to the working dir


def test_bad_topo_is_reported(tmp_path, capsys):
    assert main(["--topo", str(tmp_path / "missing.yaml")]) == 2
    assert "missing.yaml" in capsys.readouterr().err


@pytest.mark.slow
def test_process_serves_tablet_and_exits_on_sigterm(repo_root, tmp_path):
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    tablet_port = free_port()
    with zenoh.open(session_config([endpoint], [])) as session:
        robot = RobotLink(session, "bot7")
        env = dict(os.environ, QT_QPA_PLATFORM="offscreen", XDG_CONFIG_HOME=str(tmp_path))
        proc = subprocess.Popen(
            [sys.executable, "-m", "base_station_app.main", "--connect", endpoint,
             "--tablet-port", str(tablet_port), "--robot", "bot7"],
            cwd=repo_root, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
        )  # fmt: skip
        try:
            deadline = time.monotonic() + 20.0
            sock = None
            while sock is None and time.monotonic() < deadline:
                try:
                    sock = socket.create_connection(("127.0.0.1", tablet_port), timeout=1.0)
                except OSError:
                    with pytest.raises(subprocess.TimeoutExpired):
                        proc.wait(timeout=0.1)  # still running; wait for it to listen
            assert sock is not None, "station never listened for the tablet"
            sock.sendall(b'{"hello": {"protocol": 1, "client": "test"}}')
            sock.settimeout(10.0)
            data = b""
            while b"welcome" not in data:
                chunk = sock.recv(4096)
                assert chunk, "station closed the tablet connection"
                data += chunk
            welcome = json.loads(next(line for line in data.split(b"\n") if b"welcome" in line))
            assert welcome["welcome"]["protocol"] == 1
            sock.close()
            proc.send_signal(signal.SIGTERM)
            _, err = proc.communicate(timeout=15.0)
            assert proc.returncode == 0, err.decode(errors="replace")[-2000:]
            assert b"zenoh session closed" in err
        finally:
            if proc.poll() is None:
                proc.kill()
            proc.communicate()
            robot.close()
