"""Battery and BMS model: an 8-cell Li-ion pack (thesis §4.1.7, Fig. 4.1 item 1-2).

Pack: 8 cells in series, nominal 8 x 3.7 = 29.6 V, full 8 x 4.2 = 33.6 V, BMS cut-off at
8 x 3.0 = 24.0 V (cell under-voltage protection). Each cell's open-circuit voltage follows a
typical Li-ion (NMC) OCV-SOC curve (piecewise linear). A Rint equivalent circuit gives the
terminal voltage and current for the drawn power P (Plett, *Battery Management Systems*, Vol. 1,
§2.1):

    I = P / V_oc,    V = V_oc - I R,    dSOC/dt = -I / (3600 C).

The load is an idle draw (Raspberry Pi, laser, camera, converters) plus a motion draw
proportional to |v| and |omega|. The BMS latches ``cutoff`` when a cell falls to 3.0 V; then no
current flows (the simulator stops the motors). Capacity and loads are assumptions (the thesis
gives none): 20 Ah, 20 W idle, 60 W per m/s, 20 W per rad/s.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Annotated, ClassVar

import numpy as np
from msgspec import Meta

from interbot_core import schema

logger = logging.getLogger(__name__)

OCV_SOC = np.array([0.0, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0])
OCV_CELL = np.array([3.0, 3.3, 3.45, 3.55, 3.62, 3.68, 3.73, 3.8, 3.88, 3.97, 4.07, 4.2])  # [V]


class BatteryConfigError(ValueError):
    """A battery parameter is out of range; the message names the field."""


NonNegative = Annotated[float, Meta(ge=0.0, le=schema.FINITE)]


class BatteryConfig(schema.Declared, frozen=True):
    """Pack and load parameters."""

    ROOT: ClassVar[str] = "BatteryConfig"
    ERROR: ClassVar[type[Exception]] = BatteryConfigError
    cells: Annotated[int, Meta(ge=1, le=32)] = 8
    capacity_ah: Annotated[float, Meta(gt=0.0, le=schema.FINITE, extra={"unit": "Ah"})] = 20.0
    cell_full: float = 4.2  # [V]
    cell_nominal: float = 3.7  # [V]
    cell_cutoff: float = 3.0  # [V]
    internal_resistance: NonNegative = 0.08  # [ohm] pack
    idle_power: NonNegative = 20.0  # [W]
    power_per_linear: float = 60.0  # [W per m/s]
    power_per_angular: float = 20.0  # [W per rad/s]
    initial_soc: Annotated[float, Meta(ge=0.0, le=1.0)] = 1.0

    def check(self) -> None:
        if not self.cell_cutoff < self.cell_nominal < self.cell_full:
            raise BatteryConfigError("BatteryConfig needs cell_cutoff < cell_nominal < cell_full")

    @property
    def cutoff_voltage(self) -> float:
        """Pack voltage at which the BMS disconnects [V] (24.0 V)."""
        return self.cells * self.cell_cutoff


@dataclass(frozen=True)
class BatteryState:
    """What the BMS reports."""

    stamp: float  # [s]
    voltage: float  # [V] terminal
    current: float  # [A] discharge positive
    soc: float  # state of charge, 0..1
    cell_voltage: float  # [V] average terminal voltage per cell
    cutoff: bool  # the BMS has disconnected the load


def open_circuit_cell_voltage(soc: float) -> float:
    """Cell open-circuit voltage [V] at a state of charge (clamped to [0, 1])."""
    return float(np.interp(min(max(soc, 0.0), 1.0), OCV_SOC, OCV_CELL))


class Battery:
    """Deterministic pack + BMS state, stepped with the motion of the robot."""

    def __init__(self, config: BatteryConfig | None = None) -> None:
        self.config = config or BatteryConfig()
        self._soc = self.config.initial_soc
        self._current = 0.0
        self._cutoff = False
        self._stamp = 0.0
        self._update_current(self.config.idle_power)

    @property
    def cutoff(self) -> bool:
        """True once the BMS has disconnected the load (latched)."""
        return self._cutoff

    def power_demand(self, linear: float, angular: float) -> float:
        """Electrical load [W] for a body velocity."""
        c = self.config
        return c.idle_power + c.power_per_linear * abs(linear) + c.power_per_angular * abs(angular)

    def _update_current(self, power: float) -> None:
        v_oc = open_circuit_cell_voltage(self._soc) * self.config.cells
        self._current = 0.0 if self._cutoff else power / v_oc

    def step(self, dt: float, linear: float, angular: float, stamp: float) -> None:
        """Drain the pack for dt [s] at the given body velocity; ``stamp`` is the sim time."""
        c = self.config
        self._stamp = stamp
        self._update_current(self.power_demand(linear, angular))
        self._soc = max(0.0, self._soc - self._current * dt / (3600.0 * c.capacity_ah))
        if not self._cutoff and self.state().cell_voltage <= c.cell_cutoff:
            self._cutoff = True
            self._current = 0.0
            logger.warning("BMS cut-off at %.2f s: pack below %.1f V", stamp, c.cutoff_voltage)

    def state(self) -> BatteryState:
        """The current BMS report."""
        c = self.config
        v_oc = open_circuit_cell_voltage(self._soc) * c.cells
        voltage = v_oc - self._current * c.internal_resistance
        return BatteryState(
            stamp=self._stamp,
            voltage=voltage,
            current=self._current,
            soc=self._soc,
            cell_voltage=voltage / c.cells,
            cutoff=self._cutoff,
        )
