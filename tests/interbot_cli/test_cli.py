from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from interbot_cli import bench, demo
from interbot_cli.main import EXIT_NOT_BUILT, main


def test_demo_without_display_explains_how_to_proceed(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    for var in ("DISPLAY", "WAYLAND_DISPLAY", "QT_QPA_PLATFORM"):
        monkeypatch.delenv(var, raising=False)
    assert main(["demo"]) == 2
    err = capsys.readouterr().err
    assert "no display" in err and "xvfb-run" in err and "interbot scenario" in err


def test_unknown_scenario_arguments_are_usage_errors(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["scenario"])
    assert exc.value.code == 2
    assert "name" in capsys.readouterr().err


def test_bench_json_last_line_merges_figures(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "bench_a.py").write_text("def run(quick=False):\n    return {'a_ms_median': 1.5}\n")
    (tmp_path / "bench_b.py").write_text("def run():\n    return {'b_ms_p99': 2.0}\n")
    monkeypatch.setattr(bench, "BENCH_DIR", tmp_path)
    assert main(["bench", "--json", "--quick"]) == 0
    last = capsys.readouterr().out.strip().splitlines()[-1]
    assert json.loads(last) == {"a_ms_median": 1.5, "b_ms_p99": 2.0}


def test_bench_rejects_unknown_name(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "bench_a.py").write_text("def run():\n    return {}\n")
    monkeypatch.setattr(bench, "BENCH_DIR", tmp_path)
    assert main(["bench", "--only", "nope"]) == 2
    assert "unknown benchmark" in capsys.readouterr().err


def test_cli_runs_as_a_process() -> None:
    result = subprocess.run(
        [sys.executable, "-m", "interbot_cli.main", "--help"], capture_output=True, text=True
    )
    assert result.returncode == 0
    assert all(cmd in result.stdout for cmd in ("demo", "scenario", "bench"))


def test_demo_reports_parts_not_built(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv("DISPLAY", ":99")
    monkeypatch.setattr(demo, "missing_parts", lambda: ["Tablet (issue 6)"])
    assert main(["demo"]) == EXIT_NOT_BUILT
    assert "not built yet: Tablet (issue 6)" in capsys.readouterr().err


def test_demo_starts_three_programs_and_stops_them_cleanly(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """`interbot demo` on the offscreen platform: all three run, then exit on SIGTERM."""
    monkeypatch.setenv("QT_QPA_PLATFORM", "offscreen")
    monkeypatch.setenv("INTERBOT_DEMO_KEYS", str(tmp_path / "demo-keys"))  # secure demo's keys
    assert demo.missing_parts() == []
    assert main(["demo", "--duration", "6", "--people", "0"]) == 0
    assert "Base Station and Tablet running" in capsys.readouterr().out


def test_router_command_routes_between_clients_and_stops_on_sigterm(
    free_tcp_port: Any, wait_until: Any
) -> None:
    import signal

    from interbot_link import RobotLink, StationLink, open_session

    endpoint = f"tcp/127.0.0.1:{free_tcp_port()}"
    proc = subprocess.Popen(
        [sys.executable, "-m", "interbot_cli.main", "router", "--listen", endpoint],
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        import socket as _socket

        def router_up() -> bool:
            try:
                _socket.create_connection(("127.0.0.1", int(endpoint.rsplit(":", 1)[1])), 1).close()
            except OSError:
                return False
            return True

        wait_until(router_up, 15.0, "the router to listen")
        with open_session([], [endpoint], "client") as robot_session:
            link = RobotLink(robot_session, "routed")
            with open_session([], [endpoint], "client") as station_session:
                station = StationLink(station_session)
                wait_until(lambda: "routed" in station.robots, 15.0, "the robot via the router")
                station.close()
            link.close()
    finally:
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=15)
    assert proc.returncode == 0, err


def test_router_refuses_a_multicast_endpoint(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["router", "--listen", "udp/224.0.0.224:7446"]) == 2
    assert "tcp/HOST:PORT" in capsys.readouterr().err
