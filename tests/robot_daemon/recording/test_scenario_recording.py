"""``interbot scenario … --record``: a headless run with the simulator's truth on its own channel."""

from __future__ import annotations

import json
from collections import Counter
from dataclasses import replace
from pathlib import Path

from mcap.reader import make_reader

from interbot_core.supervisor import GuidedTour
from robot_daemon.recording.scenario_recording import ScenarioRecorder
from robot_daemon.scenarios.runner import ScenarioOptions, SimulatedSystem, auto_resume_tour

SIM_SECONDS = 12.0


def test_a_scenario_run_is_recorded_with_truth_tasks_and_commands(tmp_path: Path) -> None:
    path = tmp_path / "tour.mcap"
    with ScenarioRecorder(path, epoch_offset=1.7e9) as recorder:
        options = replace(ScenarioOptions(people=0), recorder=recorder)
        system = SimulatedSystem(options)
        system.hooks.append(auto_resume_tour(1.0))
        system.localise()
        system.apply(system.supervisor.submit(GuidedTour()))
        system.run_until(lambda: False, max_time=SIM_SECONDS)
        second = SimulatedSystem(options)  # a scenario may build another system
        second.run_until(lambda: False, max_time=1.0)
    counts: Counter[str] = Counter()
    times: dict[str, list[int]] = {}
    tasks, commands, truth = [], [], []
    with path.open("rb") as f:
        for _, channel, message in make_reader(f).iter_messages():
            counts[channel.topic] += 1
            times.setdefault(channel.topic, []).append(message.log_time)
            if channel.topic == "/tasks":
                tasks.append(json.loads(message.data))
            elif channel.topic == "/commands":
                commands.append(json.loads(message.data))
            elif channel.topic == "/truth":
                truth.append(json.loads(message.data))
    # Daemon rates on simulated time: 20 Hz state, 10 Hz scans, 1 Hz battery.
    total = SIM_SECONDS + 1.0
    assert abs(counts["/pose"] - 20 * total) <= 2 and counts["/truth"] == counts["/pose"]
    assert abs(counts["/scan"] - 10 * total) <= 2
    assert counts["/map"] == 2  # one per system
    for topic, stamps in times.items():
        assert stamps == sorted(stamps), f"{topic}: times go back between the two systems"
    assert {"QueueChanged", "TaskStarted", "RouteStarted"} <= {t["event"] for t in tasks}
    assert commands[0]["topic"] == "route" and commands[0]["source"] == "station (scenario)"
    moved = max(abs(t["x"] - truth[0]["x"]) + abs(t["y"] - truth[0]["y"]) for t in truth)
    assert moved > 0.5, "the robot drove on its tour"
    assert counts["/planned_path"] >= 1 and counts["/route_progress"] >= 1
