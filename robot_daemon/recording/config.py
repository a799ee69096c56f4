"""What to record and how much disk it may take: robot.yaml's ``recording:`` section.

Example (every key optional)::

    recording:
      directory: /var/lib/interbot/recordings   # relative to robot.yaml
      max_file_mb: 256        # rotate when the open file reaches this size
      max_file_minutes: 30    # ... or is this old (daemon time)
      max_total_mb: 4096      # oldest recordings are deleted first to stay under this
      camera: true            # record the camera (JPEG) as well
      queue: 2048             # messages waiting for the writer thread; beyond, drops are counted
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

import msgspec
from msgspec import Meta

from interbot_core import schema
from interbot_core.schema import SchemaError

MB = 1024 * 1024


class RecordingConfigError(ValueError):
    """Invalid ``recording:`` settings; the message names the key and the allowed range."""


@dataclass(frozen=True)
class RecordingConfig:
    """Where and how the daemon records (sizes in bytes, durations in seconds)."""

    directory: Path
    max_file_bytes: int = 256 * MB
    max_file_seconds: float = 1800.0  # [s]
    max_total_bytes: int = 4096 * MB
    camera: bool = True
    queue: int = 2048

    def __post_init__(self) -> None:
        # Each value's range is declared in `RecordingSection`; this rule spans two of them.
        if self.max_total_bytes < 2 * self.max_file_bytes:
            raise RecordingConfigError(
                f"recording: 'max_total_mb' ({self.max_total_bytes / MB:g}) must be at least "
                f"twice 'max_file_mb' ({self.max_file_bytes / MB:g}): one file is being written "
                "while the older ones are kept"
            )

    @classmethod
    def from_mapping(
        cls, raw: Mapping[str, Any], base_dir: Path, directory: Path | None = None
    ) -> RecordingConfig:
        """Parse robot.yaml's ``recording:`` mapping (``directory`` overrides its directory)."""
        try:
            doc = schema.convert(raw, RecordingSection, "recording")
        except SchemaError as exc:
            raise RecordingConfigError(exc.key_message()) from None
        if directory is None:
            if doc.directory is None:
                raise RecordingConfigError("recording: 'directory' must be a directory path")
            directory = (base_dir / doc.directory).resolve()
        return cls(
            directory=directory,
            max_file_bytes=int(doc.max_file_mb * MB),
            max_file_seconds=doc.max_file_minutes * 60.0,
            max_total_bytes=int(doc.max_total_mb * MB),
            camera=doc.camera,
            queue=doc.queue,
        )


class RecordingSection(msgspec.Struct, frozen=True, forbid_unknown_fields=True):
    """The ``recording:`` mapping as written in robot.yaml (sizes in MB, durations in minutes)."""

    directory: Annotated[str, Meta(min_length=1, extra={"format": "a directory path"})] | None = (
        None
    )
    max_file_mb: Annotated[float, Meta(ge=0.01, le=1 << 20)] = 256
    max_file_minutes: Annotated[float, Meta(ge=0.01, le=24 * 60)] = 30
    max_total_mb: Annotated[float, Meta(ge=0.02, le=1 << 24)] = 4096
    camera: bool = True
    queue: Annotated[int, Meta(ge=16, le=1 << 20)] = 2048
