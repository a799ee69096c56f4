"""Device emulators written from the protocol specifications, served on pseudo-terminals: test
doubles of the laser and the motor controller (issue 13 keeps test doubles out of the product).

`pty_port.PtyPort` is the shared pseudo-terminal (with an optional stable symlink, so an
"unplug" and "replug" keeps the configured path, as a udev ``/dev/serial/by-id`` link does).
Run from a checkout: ``python -m tests.robot_daemon.hardware.emulators.hokuyo_emulator --pty``.
"""
