"""The Foxglove layout in docs/ is the one the code builds, in the app's import format."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[2]
DOC = REPO / "docs" / "foxglove_layout.json"
_spec = importlib.util.spec_from_file_location(
    "foxglove_layout", REPO / "tools" / "foxglove_layout.py"
)
assert _spec is not None and _spec.loader is not None
_tool = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_tool)  # tools/ is not a package: loaded by its path
layout_json = _tool.layout_json


def test_the_shipped_layout_is_up_to_date() -> None:
    assert DOC.read_text(encoding="utf-8") == layout_json(), (
        "regenerate: python tools/foxglove_layout.py > docs/foxglove_layout.json"
    )


def _leaves(node: Any) -> list[str]:
    if isinstance(node, str):
        return [node]
    assert set(node) == {"direction", "first", "second", "splitPercentage"}
    assert node["direction"] in ("row", "column") and 0 < node["splitPercentage"] < 100
    return _leaves(node["first"]) + _leaves(node["second"])


def test_the_layout_shows_map_scan_robot_route_and_camera() -> None:
    layout = json.loads(DOC.read_text(encoding="utf-8"))
    assert set(layout) == {"configById", "globalVariables", "userNodes", "playbackConfig", "layout"}
    panels = layout["configById"]
    assert sorted(_leaves(layout["layout"])) == sorted(panels)  # every leaf configured, no extra
    kinds = {panel_id.split("!")[0] for panel_id in panels}
    assert kinds == {"3D", "Image", "Plot", "RawMessages"}
    scene = next(config for panel_id, config in panels.items() if panel_id.startswith("3D!"))
    assert {"/map", "/scan", "/route", "/planned_path"} <= set(scene["topics"])
    assert scene["followTf"] == "base_link"  # the robot, from /tf
    image = next(config for panel_id, config in panels.items() if panel_id.startswith("Image!"))
    assert image["imageMode"]["imageTopic"] == "/camera/image/compressed"
    plot = next(config for panel_id, config in panels.items() if panel_id.startswith("Plot!"))
    assert [p["value"] for p in plot["paths"]] == ["/cmd_vel.linear", "/cmd_vel.angular"]
