"""The Foxglove layout shipped in ``docs/foxglove_layout.json`` (built with ``foxglove.layouts``).

A 3D panel with the map (Grid, occupancy 0..100 from white to black), the laser scan, the robot
(the ``base_link`` frame of ``/tf``, followed), the station's route and the planner's path; beside
it the camera, the velocity the mux sent to the motors, and the station's commands.

    .venv/bin/python -m robot_daemon.recording.foxglove_layout > docs/foxglove_layout.json
"""

from __future__ import annotations

import json

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
                            fl.PlotSeries(value="/cmd_vel.linear", label="linear [m/s]"),
                            fl.PlotSeries(value="/cmd_vel.angular", label="angular [rad/s]"),
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


def layout_json() -> str:
    """The layout, indented, with a final newline (as stored in docs/)."""
    return json.dumps(json.loads(build_layout().to_json()), indent=2) + "\n"


if __name__ == "__main__":
    print(layout_json(), end="")
