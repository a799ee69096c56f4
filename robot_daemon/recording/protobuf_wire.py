"""A minimal reader of the protobuf wire format, for the Foxglove schemas the recorder writes.

The replay decodes ``foxglove.Grid``, ``foxglove.LaserScan`` and ``foxglove.CompressedImage``
without the protobuf runtime: the wire format is tag varints (``field << 3 | wire type``) and
four wire types (protobuf "Encoding" guide). Field numbers come from Foxglove's ``.proto``
files; the tests check them against the schema descriptor stored in the recording itself.
"""

from __future__ import annotations

import struct
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from interbot_core.laser_scan import LaserScan
from interbot_core.occupancy_grid import OccupancyGrid

VARINT, FIXED64, LENGTH, FIXED32 = 0, 1, 2, 5


class WireError(ValueError):
    """A protobuf payload is truncated or malformed."""


def read_varint(data: bytes, i: int) -> tuple[int, int]:
    """The varint at ``data[i:]`` and the index after it."""
    result = shift = 0
    while True:
        if i >= len(data):
            raise WireError("truncated varint")
        byte = data[i]
        i += 1
        result |= (byte & 0x7F) << shift
        if not byte & 0x80:
            return result, i
        shift += 7
        if shift > 63:
            raise WireError("varint longer than 10 bytes")


def fields(data: bytes) -> Iterator[tuple[int, int, int | bytes]]:
    """(field number, wire type, value) for every field of one message, in order.

    Varints come as int, fixed64/fixed32 as their raw 8/4 bytes, length-delimited as bytes.
    """
    i, n = 0, len(data)
    while i < n:
        tag, i = read_varint(data, i)
        number, wire = tag >> 3, tag & 7
        value: int | bytes
        if wire == VARINT:
            value, i = read_varint(data, i)
        elif wire == FIXED64:
            value, i = data[i : i + 8], i + 8
        elif wire == FIXED32:
            value, i = data[i : i + 4], i + 4
        elif wire == LENGTH:
            length, i = read_varint(data, i)
            value, i = data[i : i + length], i + length
        else:
            raise WireError(f"unsupported wire type {wire} (field {number})")
        if i > n:
            raise WireError(f"field {number} runs past the end of the message")
        yield number, wire, value


def last_fields(data: bytes) -> dict[int, int | bytes]:
    """{field number: value} of one message; a repeated field keeps its last value, as protobuf
    does for a scalar (no decoder here reads a repeated field)."""
    return {number: value for number, _, value in fields(data)}


def _double(value: int | bytes) -> float:
    if not isinstance(value, bytes) or len(value) != 8:
        raise WireError("expected a fixed64 double")
    return float(struct.unpack("<d", value)[0])


def _bytes(value: int | bytes) -> bytes:
    if not isinstance(value, bytes):
        raise WireError("expected a length-delimited field")
    return value


def _int(value: int | bytes) -> int:
    """A varint or a fixed32 (Foxglove declares counts and strides ``fixed32``)."""
    if isinstance(value, bytes):
        if len(value) != 4:
            raise WireError("expected a varint or a fixed32")
        return int.from_bytes(value, "little")
    return value


def timestamp(data: bytes) -> float:
    """google.protobuf.Timestamp (1 seconds, 2 nanos) -> seconds."""
    f = last_fields(data)
    return _int(f.get(1, 0)) + _int(f.get(2, 0)) * 1e-9


def vector(data: bytes) -> tuple[float, float, float, float]:
    """foxglove.Vector2/Vector3/Quaternion: fields 1..4 are x, y, z, w (doubles)."""
    out = [0.0, 0.0, 0.0, 0.0]
    for number, _, value in fields(data):
        if 1 <= number <= 4:
            out[number - 1] = _double(value)
    return out[0], out[1], out[2], out[3]


@dataclass(frozen=True)
class Pose3:
    x: float
    y: float
    yaw: float


def pose(data: bytes) -> Pose3:
    """foxglove.Pose (1 position, 2 orientation) as a planar pose (yaw about z)."""
    f = last_fields(data)
    x, y, _, _ = vector(_bytes(f[1])) if 1 in f else (0.0, 0.0, 0.0, 0.0)
    _, _, qz, qw = vector(_bytes(f[2])) if 2 in f else (0.0, 0.0, 0.0, 1.0)
    return Pose3(x, y, 2.0 * float(np.arctan2(qz, qw)))


def decode_grid(data: bytes) -> OccupancyGrid:
    """foxglove.Grid (1 timestamp, 2 frame_id, 3 pose, 4 column_count, 5 cell_size,
    6 row_stride, 7 cell_stride, 8 fields, 9 data) written by `foxglove_convert.grid_message`."""
    f = last_fields(data)
    origin = pose(_bytes(f[3])) if 3 in f else Pose3(0.0, 0.0, 0.0)
    columns, row_stride, cell_stride = (_int(f.get(n, 0)) for n in (4, 6, 7))
    cell = vector(_bytes(f[5]))[0] if 5 in f else 0.0
    payload = _bytes(f.get(9, b""))
    if cell_stride != 1 or columns <= 0 or row_stride != columns or cell <= 0:
        raise WireError(
            f"grid layout not from this recorder (columns {columns}, row_stride {row_stride}, "
            f"cell_stride {cell_stride}, cell {cell})"
        )
    if len(payload) % columns:
        raise WireError(f"grid data ({len(payload)} bytes) is not whole rows of {columns}")
    cells: npt.NDArray[np.int8] = np.frombuffer(payload, dtype=np.int8).reshape(-1, columns).copy()
    return OccupancyGrid(cells, cell, origin.x, origin.y, origin.yaw, source="recording")


def decode_laser_scan(data: bytes, range_min: float, range_max: float) -> LaserScan:
    """foxglove.LaserScan (1 timestamp, 2 frame_id, 3 pose, 4 start_angle, 5 end_angle,
    6 ranges packed doubles, 7 intensities)."""
    stamp = start = end = 0.0
    ranges: npt.NDArray[np.float64] = np.zeros(0)
    for number, wire, value in fields(data):
        if number == 1:
            stamp = timestamp(_bytes(value))
        elif number == 4:
            start = _double(value)
        elif number == 5:
            end = _double(value)
        elif number == 6 and wire == LENGTH:
            ranges = np.frombuffer(_bytes(value), dtype="<f8")
    if ranges.size < 2:
        raise WireError("laser scan with fewer than two ranges")
    increment = (end - start) / (ranges.size - 1)
    return LaserScan(stamp, start, increment, range_min, range_max, ranges.astype(np.float32))


def decode_compressed_image(data: bytes) -> tuple[float, str, bytes]:
    """foxglove.CompressedImage (1 timestamp, 4 frame_id, 2 data, 3 format) -> (stamp, format, data)."""
    f = last_fields(data)
    stamp = timestamp(_bytes(f[1])) if 1 in f else 0.0
    fmt = _bytes(f.get(3, b"")).decode("utf-8", "replace")
    return stamp, fmt, _bytes(f.get(2, b""))


def descriptor_fields(file_descriptor_set: bytes) -> dict[str, dict[str, int]]:
    """{message name: {field name: number}} from a serialized ``FileDescriptorSet``.

    (FileDescriptorSet.file = 1; FileDescriptorProto.package = 2, message_type = 4;
    DescriptorProto.name = 1, field = 2; FieldDescriptorProto.name = 1, number = 3.)
    """
    out: dict[str, dict[str, int]] = {}
    for number, _, file in fields(file_descriptor_set):
        if number != 1:
            continue
        package = ""
        messages = []
        for n, _, value in fields(_bytes(file)):
            if n == 2:
                package = _bytes(value).decode()
            elif n == 4:
                messages.append(_bytes(value))
        for message in messages:
            name, numbers = "", {}
            for n, _, value in fields(message):
                if n == 1:
                    name = _bytes(value).decode()
                elif n == 2:
                    spec = {k: v for k, _, v in fields(_bytes(value))}
                    numbers[_bytes(spec[1]).decode()] = _int(spec[3])
            out[f"{package}.{name}" if package else name] = numbers
    return out


EXPECTED_FIELDS: dict[str, dict[str, int]] = {
    "foxglove.Grid": {
        "pose": 3,
        "column_count": 4,
        "cell_size": 5,
        "row_stride": 6,
        "cell_stride": 7,
        "data": 9,
    },
    "foxglove.LaserScan": {"timestamp": 1, "start_angle": 4, "end_angle": 5, "ranges": 6},
    "foxglove.CompressedImage": {"timestamp": 1, "data": 2, "format": 3},
    "foxglove.Pose": {"position": 1, "orientation": 2},
    "foxglove.Vector2": {"x": 1, "y": 2},
    "foxglove.Vector3": {"x": 1, "y": 2, "z": 3},
    "foxglove.Quaternion": {"x": 1, "y": 2, "z": 3, "w": 4},
    "google.protobuf.Timestamp": {"seconds": 1, "nanos": 2},
}
"""The field numbers the decoders above rely on."""


def check_schema(schema_name: str, file_descriptor_set: bytes) -> None:
    """Raise WireError if a recording's schema numbers the fields these decoders read differently."""
    found = descriptor_fields(file_descriptor_set)
    for message, expected in EXPECTED_FIELDS.items():
        if message not in found:
            continue
        wrong = {
            k: found[message].get(k) for k, v in expected.items() if found[message].get(k) != v
        }
        if wrong:
            raise WireError(f"{schema_name}: {message} fields {wrong} differ from {expected}")
    if schema_name not in found:
        raise WireError(f"schema {schema_name} is not described in its own descriptor set")
