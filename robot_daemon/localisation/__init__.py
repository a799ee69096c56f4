"""Localisation on an a-priori map: Hector scan matching, odometry prior, loss detection and
map updates for new static obstacles (thesis §3.2 and §4.2.3.1)."""

from __future__ import annotations

from robot_daemon.localisation.dynamic_map import DynamicEvidenceGrid, DynamicMapConfig
from robot_daemon.localisation.localiser import (
    Localiser,
    LocaliserConfig,
    LocaliserEstimate,
    LocaliserState,
)
from robot_daemon.localisation.scan_matcher import MatchResult, ScanMatcher, ScanMatcherConfig

__all__ = [
    "DynamicEvidenceGrid",
    "DynamicMapConfig",
    "Localiser",
    "LocaliserConfig",
    "LocaliserEstimate",
    "LocaliserState",
    "MatchResult",
    "ScanMatcher",
    "ScanMatcherConfig",
]
