"""The Foxglove layout shipped in ``docs/foxglove_layout.json`` (built with ``foxglove.layouts``).

Written in the app's import format (`app_layout`). A 3D panel with the map (Grid, occupancy 0..100 from white to black), the laser scan, the robot
(the ``base_link`` frame of ``/tf``, followed), the station's route and the planner's path; beside
it the camera, the velocity the mux sent to the motors, and the station's commands.

    .venv/bin/python tools/foxglove_layout.py > docs/foxglove_layout.json

An authoring tool (it writes a file in docs/), so it lives in tools/, not in what the robot runs.
"""

from __future__ import annotations

import json
from typing import Any

import foxglove.layouts as fl

from robot_daemon.recording.recorder import CAMERA_JPEG, COMMANDS, MAP, PLANNED_PATH, ROUTE, SCAN

LAYOUT_TOPICS = (MAP, SCAN, ROUTE, PLANNED_PATH, CAMERA_JPEG, COMMANDS, "/cmd_vel", "/tf")


def build_layout() -> fl.Layout:
    scene = fl.ThreeDeePanel(
        title="Map, scan, robot, route",
        config=fl.ThreeDeeConfig(
            follow_tf="base_link",
            follow_mode="follow-position",
            topics={
                MAP: fl.BaseRendererGridTopicSettings(
                    visible=True,
                    color_mode="gradient",
                    color_field="occupancy",
                    gradient=("#f0f0f0ff", "#000000ff"),
                    min_value=0.0,
                    max_value=100.0,
                ),
                SCAN: fl.BaseRendererLaserScanTopicSettings(
                    visible=True, point_size=4.0, color_mode="flat", flat_color="#e03030ff"
                ),
                ROUTE: fl.BaseRendererPosesTopicSettings(
                    visible=True, type="arrow", arrow_scale=(0.6, 0.15, 0.15)
                ),
                PLANNED_PATH: fl.BaseRendererPosesTopicSettings(
                    visible=True, type="line", line_width=0.05, gradient=("#2060ffff", "#2060ffff")
                ),
            },
        ),
    )
    side = fl.SplitContainer(
        direction="column",
        items=[
            fl.SplitItem(
                proportion=2,
                content=fl.ImagePanel(
                    title="Camera",
                    config=fl.ImageConfig(image_mode=fl.ImageModeConfig(image_topic=CAMERA_JPEG)),
                ),
            ),
            fl.SplitItem(
                content=fl.PlotPanel(
                    title="cmd_vel",
                    config=fl.PlotConfig(
                        paths=[
                            fl.PlotSeries(
                                value="/cmd_vel.linear", label="linear [m/s]", enabled=True
                            ),
                            fl.PlotSeries(
                                value="/cmd_vel.angular", label="angular [rad/s]", enabled=True
                            ),
                        ]
                    ),
                ),
            ),
            fl.SplitItem(
                content=fl.RawMessagesPanel(
                    title="Station commands", config=fl.RawMessagesConfig(topic_path=COMMANDS)
                ),
            ),
        ],
    )
    return fl.Layout(
        content=fl.SplitContainer(
            direction="row",
            items=[fl.SplitItem(proportion=2, content=scene), fl.SplitItem(content=side)],
        )
    )


PANEL_ID_PREFIX = {"ThreeDee": "3D"}  # the app's panel ids: "3D!…", "Image!…", "Plot!…"


def app_layout(layout: fl.Layout) -> dict[str, Any]:
    """The layout in the form the Foxglove app imports and exports (*Layout → Import from file*).

    The SDK's model (``version`` 1, a tree of splits) is converted to the app's: panel configs by
    id in ``configById`` (the title as ``foxglovePanelTitle``) and a binary mosaic tree of
    ``{"direction", "first", "second", "splitPercentage"}`` in ``layout``.
    """
    config_by_id: dict[str, dict[str, Any]] = {}

    def node(content: dict[str, Any]) -> str | dict[str, Any]:
        if content["type"] == "panel":
            kind = content["panelType"]
            panel_id = f"{PANEL_ID_PREFIX.get(kind, kind)}!{len(config_by_id) + 1}"
            config = dict(content.get("config") or {})
            if content.get("title"):
                config["foxglovePanelTitle"] = content["title"]
            config_by_id[panel_id] = config
            return panel_id
        if content["type"] != "split":
            raise ValueError(f"layout container {content['type']!r} is not converted")
        return split(content["direction"], content["items"])

    def split(direction: str, items: list[dict[str, Any]]) -> str | dict[str, Any]:
        first = node(items[0]["content"])
        if len(items) == 1:
            return first
        total = sum(float(item.get("proportion", 1)) for item in items)
        share = float(items[0].get("proportion", 1)) / total
        return {
            "direction": direction,
            "first": first,
            "second": split(direction, items[1:]),
            "splitPercentage": round(100.0 * share, 1),
        }

    tree = node(json.loads(layout.to_json())["content"])
    return {
        "configById": config_by_id,
        "globalVariables": {},
        "userNodes": {},
        "playbackConfig": {"speed": 1},
        "layout": tree,
    }


def layout_json() -> str:
    """The app's layout file, indented, with a final newline (as stored in docs/)."""
    return json.dumps(app_layout(build_layout()), indent=2) + "\n"


if __name__ == "__main__":
    print(layout_json(), end="")
