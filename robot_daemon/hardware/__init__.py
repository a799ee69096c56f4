"""Drivers for the real Interbot devices (thesis §4.1): Hokuyo UTM-30LX laser (SCIP 2.0),
RoboteQ motor controller (serial command protocol), Logitech USB camera (OpenCV), and the
`HardwareBackend` that presents them to the daemon as a `robot_daemon.backend.RobotBackend`.

Protocol framing lives in pure modules (`scip`, `roboteq`) tested without serial ports; the
drivers (`hokuyo_driver`, `roboteq_driver`, `camera`) own the I/O and are tested against the
emulators in `tests/robot_daemon/hardware/emulators/` on pseudo-terminals (test doubles,
not shipped).
"""
