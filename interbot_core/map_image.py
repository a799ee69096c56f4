"""An occupancy grid as a grey image: the one conversion both apps draw their floor with.

Free cells light, occupied dark, unknown in between (each app picks its grey levels); row 0 is
the grid's bottom row (lowest y), as in `OccupancyGrid`. A widget that draws top row first
flips it (``image[::-1]``).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from interbot_core.occupancy_grid import FREE, OCCUPIED, OccupancyGrid


def grey_image(
    grid: OccupancyGrid, free: int = 255, occupied: int = 0, unknown: int = 200
) -> npt.NDArray[np.uint8]:
    """``uint8`` grey levels of the cells, row-major, C-contiguous (levels 0..255)."""
    for name, level in (("free", free), ("occupied", occupied), ("unknown", unknown)):
        if not 0 <= level <= 255:
            raise ValueError(f"grey level '{name}' must be in 0..255, got {level!r}")
    image = np.full(grid.cells.shape, unknown, dtype=np.uint8)
    image[grid.cells == FREE] = free
    image[grid.cells == OCCUPIED] = occupied
    return image
