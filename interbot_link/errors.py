"""Errors of the zenoh link (one module, so the session and the security layer share them)."""

from __future__ import annotations


class LinkError(Exception):
    """Base class for errors of the zenoh link."""


class LinkConfigError(LinkError, ValueError):
    """A session configuration is unsafe or malformed; the message names the offending value."""


class InsecureEndpointError(LinkConfigError):
    """A plaintext endpoint off the loopback interface without ``--insecure``."""


class LinkOpenError(LinkError):
    """zenoh could not open the session (e.g. the listen port is taken)."""
