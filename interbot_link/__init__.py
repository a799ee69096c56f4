"""zenoh glue shared by the robot daemon and the Base Station (no Qt).

`session_config` / `open_session` build safe sessions (no scouting, explicit endpoints,
bounded lease; with `LinkSecurity`, mutual TLS and access control); `RobotLink` is the robot's end, `StationLink` the station's. Keys and payload
codecs live in `interbot_core.topics`; see docs/topics.md.
"""

from __future__ import annotations

from interbot_link.keys import KeysError, KeyStore
from interbot_link.robot import Command, LinkClosedError, RobotLink
from interbot_link.security import LinkSecurity
from interbot_link.session import (
    InsecureEndpointError,
    LinkConfigError,
    LinkError,
    LinkOpenError,
    open_session,
    session_config,
    validate_endpoint,
)
from interbot_link.station import (
    LinkEvent,
    NoRobotSelectedError,
    RobotAppeared,
    RobotLeft,
    StateMessage,
    StationLink,
)

__all__ = [
    "Command",
    "InsecureEndpointError",
    "KeyStore",
    "KeysError",
    "LinkClosedError",
    "LinkConfigError",
    "LinkError",
    "LinkEvent",
    "LinkOpenError",
    "LinkSecurity",
    "NoRobotSelectedError",
    "RobotAppeared",
    "RobotLeft",
    "RobotLink",
    "StateMessage",
    "StationLink",
    "open_session",
    "session_config",
    "validate_endpoint",
]
