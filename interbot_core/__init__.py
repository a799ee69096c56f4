"""Interbot shared core: Qt-free, deterministic logic used by the station, tablet and daemon."""
