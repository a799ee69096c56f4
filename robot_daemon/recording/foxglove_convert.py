"""Interbot's messages in Foxglove's well-known schemas (REP-103/105 frames: map, odom, base_link).

Times: Foxglove shows wall-clock dates, so a message stamped ``now`` [s of daemon time] gets
``epoch_offset + now`` (the daemon passes the wall time of its time zero). The map goes out as a
``Grid`` of int8 occupancy (-1 unknown, 0..100) in the map_server convention: row 0 at the map's
origin, rows towards +y, which is also how Foxglove lays out a grid's rows.

The replay reads them back (`grid_from`, `scan_from`) with the protobuf runtime, its message
classes built from the descriptors the recording stores beside its channels (`message_class`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from foxglove.messages import (
    CompressedImage,
    FrameTransform,
    FrameTransforms,
    Grid,
    PackedElementField,
    PackedElementFieldNumericType,
    Pose,
    PosesInFrame,
    Quaternion,
    Timestamp,
    Vector2,
    Vector3,
)
from foxglove.messages import LaserScan as FoxgloveLaserScan
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from google.protobuf.message import Message

from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import LaserScan
from interbot_core.occupancy_grid import OccupancyGrid

MAP_FRAME = "map"
ODOM_FRAME = "odom"
BASE_FRAME = "base_link"
LASER_FRAME = "laser"
CAMERA_FRAME = "camera"


def stamp(t: float) -> Timestamp:
    """Seconds since the epoch -> foxglove Timestamp (sec, nsec)."""
    sec = math.floor(t)
    nsec = min(round((t - sec) * 1e9), 999_999_999)
    return Timestamp(sec, nsec)


def yaw_quaternion(yaw: float) -> Quaternion:
    """Rotation by ``yaw`` about z: (0, 0, sin(yaw/2), cos(yaw/2))."""
    return Quaternion(x=0.0, y=0.0, z=math.sin(yaw / 2.0), w=math.cos(yaw / 2.0))


def planar_pose(pose: Pose2D) -> Pose:
    return Pose(position=Vector3(x=pose.x, y=pose.y, z=0.0), orientation=yaw_quaternion(pose.yaw))


def transform(t: float, parent: str, child: str, pose: Pose2D) -> FrameTransform:
    """The pose of frame ``child`` in frame ``parent``."""
    return FrameTransform(
        timestamp=stamp(t),
        parent_frame_id=parent,
        child_frame_id=child,
        translation=Vector3(x=pose.x, y=pose.y, z=0.0),
        rotation=yaw_quaternion(pose.yaw),
    )


def robot_transforms(
    t: float, map_pose: Pose2D | None, odom_pose: Pose2D | None
) -> FrameTransforms:
    """map→odom→base_link (REP-105): ``map→odom = map_pose ⊕ odom_pose⁻¹``.

    Without a localised pose only odom→base_link goes out; without odometry, map→base_link
    is given through an identity odom frame.
    """
    transforms = []
    if odom_pose is not None:
        if map_pose is not None:
            map_to_odom = map_pose.compose(odom_pose.inverse())
            transforms.append(transform(t, MAP_FRAME, ODOM_FRAME, map_to_odom))
        transforms.append(transform(t, ODOM_FRAME, BASE_FRAME, odom_pose))
    elif map_pose is not None:
        transforms.append(transform(t, MAP_FRAME, ODOM_FRAME, Pose2D(0.0, 0.0, 0.0)))
        transforms.append(transform(t, ODOM_FRAME, BASE_FRAME, map_pose))
    return FrameTransforms(transforms=transforms)


def laser_mount_transform(t: float, mount: Pose2D) -> FrameTransforms:
    return FrameTransforms(transforms=[transform(t, BASE_FRAME, LASER_FRAME, mount)])


def grid_message(t: float, grid: OccupancyGrid) -> Grid:
    """The occupancy grid as a foxglove Grid of int8 cells, row-major from the origin."""
    cells = np.ascontiguousarray(grid.cells, dtype=np.int8)
    return Grid(
        timestamp=stamp(t),
        frame_id=MAP_FRAME,
        pose=planar_pose(Pose2D(grid.origin_x, grid.origin_y, grid.origin_yaw)),
        column_count=int(cells.shape[1]),
        cell_size=Vector2(x=grid.resolution, y=grid.resolution),
        row_stride=int(cells.shape[1]),
        cell_stride=1,
        fields=[
            PackedElementField(name="occupancy", offset=0, type=PackedElementFieldNumericType.Int8)
        ],
        data=cells.tobytes(),
    )


def scan_message(t: float, scan: LaserScan) -> FoxgloveLaserScan:
    """A planar scan in the laser frame; beams outside [range_min, range_max] become NaN."""
    ranges = np.where(scan.valid(), scan.ranges, np.nan).astype(np.float64)
    end = scan.angle_min + scan.angle_increment * (ranges.size - 1)
    return FoxgloveLaserScan(
        timestamp=stamp(t),
        frame_id=LASER_FRAME,
        pose=planar_pose(Pose2D(0.0, 0.0, 0.0)),
        start_angle=scan.angle_min,
        end_angle=end,
        ranges=ranges.tolist(),
    )


def path_message(t: float, poses: Sequence[tuple[float, float, float]]) -> PosesInFrame:
    """A route or planned path: (x, y, yaw) points in the map frame."""
    return PosesInFrame(
        timestamp=stamp(t),
        frame_id=MAP_FRAME,
        poses=[planar_pose(Pose2D(x, y, yaw)) for x, y, yaw in poses],
    )


def path_with_headings(points: Sequence[tuple[float, float]]) -> list[tuple[float, float, float]]:
    """(x, y) path points with the heading of each segment (the last repeats the previous)."""
    out: list[tuple[float, float, float]] = []
    for i, (x, y) in enumerate(points):
        j = min(i + 1, len(points) - 1)
        k = j - 1 if j == i else i
        nx, ny = points[j]
        px, py = points[k]
        yaw = math.atan2(ny - py, nx - px) if (nx, ny) != (px, py) else 0.0
        out.append((x, y, yaw))
    return out


def jpeg_message(t: float, jpeg: bytes) -> CompressedImage:
    return CompressedImage(timestamp=stamp(t), frame_id=CAMERA_FRAME, data=jpeg, format="jpeg")


# -- back from a recording ------------------------------------------------------------------


def message_class(schema: str, descriptor_set: bytes) -> type[Message]:
    """The protobuf class of ``schema`` (``foxglove.Grid`` ...) from a serialised
    ``FileDescriptorSet``, as MCAP stores it with a channel's schema. Raises DecodeError,
    TypeError or KeyError for a descriptor set that does not describe it."""
    pool = descriptor_pool.DescriptorPool()
    for file in descriptor_pb2.FileDescriptorSet.FromString(descriptor_set).file:
        pool.Add(file)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(schema))


def seconds(timestamp: Any) -> float:
    """A ``google.protobuf.Timestamp`` in seconds."""
    return float(timestamp.seconds + timestamp.nanos * 1e-9)


def grid_from(message: Any) -> OccupancyGrid:
    """A decoded foxglove Grid written by `grid_message`, as the map again."""
    columns, cell = message.column_count, message.cell_size.x
    if message.cell_stride != 1 or columns <= 0 or message.row_stride != columns or cell <= 0:
        raise ValueError(
            f"grid layout not from this recorder (columns {columns}, row_stride "
            f"{message.row_stride}, cell_stride {message.cell_stride}, cell {cell})"
        )
    if len(message.data) % columns:
        raise ValueError(f"grid data ({len(message.data)} bytes) is not whole rows of {columns}")
    cells = np.frombuffer(message.data, dtype=np.int8).reshape(-1, columns).copy()
    origin, turn = message.pose.position, message.pose.orientation
    yaw = 2.0 * math.atan2(turn.z, turn.w)
    return OccupancyGrid(cells, cell, origin.x, origin.y, yaw, source="recording")


def scan_from(message: Any, range_min: float, range_max: float) -> LaserScan:
    """A decoded foxglove LaserScan written by `scan_message` (NaN beams stay NaN)."""
    ranges = np.asarray(message.ranges, dtype=np.float64)
    if ranges.size < 2:
        raise ValueError("laser scan with fewer than two ranges")
    start, end = message.start_angle, message.end_angle
    increment = (end - start) / (ranges.size - 1)
    return LaserScan(
        seconds(message.timestamp),
        start,
        increment,
        range_min,
        range_max,
        ranges.astype(np.float32),
    )
