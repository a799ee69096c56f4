"""The Foxglove layout in docs/ is the one the code builds, and shows channels the recorder writes."""

from __future__ import annotations

import json
from pathlib import Path

from robot_daemon.recording.foxglove_layout import LAYOUT_TOPICS, layout_json

DOC = Path(__file__).resolve().parents[3] / "docs" / "foxglove_layout.json"


def test_the_shipped_layout_is_up_to_date() -> None:
    assert DOC.read_text(encoding="utf-8") == layout_json(), (
        "regenerate: python -m robot_daemon.recording.foxglove_layout > docs/foxglove_layout.json"
    )


def test_the_layout_shows_map_scan_robot_route_and_camera() -> None:
    layout = json.loads(DOC.read_text(encoding="utf-8"))
    text = json.dumps(layout)
    panels = []

    def walk(node: object) -> None:
        if isinstance(node, dict):
            if node.get("type") == "panel":
                panels.append(node)
            for value in node.values():
                walk(value)
        elif isinstance(node, list):
            for value in node:
                walk(value)

    walk(layout)
    kinds = {p["panelType"] for p in panels}
    assert {"ThreeDee", "Image", "Plot", "RawMessages"} <= kinds
    scene = next(p for p in panels if p["panelType"] == "ThreeDee")
    assert {"/map", "/scan", "/route", "/planned_path"} <= set(scene["config"]["topics"])
    assert scene["config"]["followTf"] == "base_link"  # the robot, from /tf
    assert "/camera/image/compressed" in text
    for topic in LAYOUT_TOPICS:
        assert topic.startswith("/")
