"""Device emulators written from the protocol specifications, served on pseudo-terminals.

`pty_port.PtyPort` is the shared pseudo-terminal (with an optional stable symlink, so an
"unplug" and "replug" keeps the configured path, as a udev ``/dev/serial/by-id`` link does).
"""
