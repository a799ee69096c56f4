"""Device health as the station's alerts need it: faults and contacts said once, when they begin.

The backends report each device's health (`RobotBackend.device_status`): a RoboteQ fault flag
(stall, over-current, ...) makes the motors not ok; a contact (the motors stalled against an
obstacle: on the simulated robot its contact sensor, on hardware the controller's stall fault)
increments the motors' ``contacts`` counter. `DeviceHealth.changes` compares with the previous
report and returns the status lines to publish: ``"collision: ..."`` for new contacts and
``"fault: ..."`` for a device that stopped being ok, which the station turns into alerts
(`base_station_app.alerts`). A persisting fault is said once; its clearing is said too.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from robot_daemon.backend import DeviceStatus


@dataclass
class DeviceHealth:
    _ok: dict[str, bool] = field(default_factory=dict)
    _contacts: dict[str, int] = field(default_factory=dict)

    def changes(self, devices: list[DeviceStatus]) -> list[tuple[str, str]]:
        """``(level, text)`` status lines for what changed since the last call."""
        lines: list[tuple[str, str]] = []
        for device in devices:
            was_ok = self._ok.get(device.name, True)
            if was_ok and not device.ok:
                lines.append(("error", f"fault: {device.name}: {device.message}"))
            elif not was_ok and device.ok:
                lines.append(("info", f"{device.name} healthy again: {device.message}"))
            self._ok[device.name] = device.ok
            contacts = device.counters.get("contacts")
            if contacts is not None:
                before = self._contacts.get(device.name, contacts)
                if contacts > before:
                    new = contacts - before
                    count = f"{new} new contact{'s' if new > 1 else ''}, {contacts} since start"
                    text = f"collision: {device.name} stalled against an obstacle ({count})"
                    lines.append(("error", text))
                self._contacts[device.name] = contacts
        return lines
