"""`interbot_core.map_image.grey_image`: the one grid-to-image conversion of both apps."""

from __future__ import annotations

import numpy as np
import pytest

from interbot_core.map_image import grey_image
from interbot_core.occupancy_grid import FREE, OCCUPIED, UNKNOWN, OccupancyGrid


def test_free_light_occupied_dark_unknown_between_row_zero_at_the_bottom() -> None:
    cells = np.array([[FREE, OCCUPIED], [UNKNOWN, FREE]], dtype=np.int8)
    grid = OccupancyGrid(cells, 0.05, 0.0, 0.0)
    assert grey_image(grid).tolist() == [[255, 0], [200, 255]]
    soft = grey_image(grid, free=250, occupied=40, unknown=205)
    assert soft.dtype == np.uint8 and soft.flags.c_contiguous
    assert soft.tolist() == [[250, 40], [205, 250]]
    with pytest.raises(ValueError, match=r"grey level 'occupied' must be in 0\.\.255"):
        grey_image(grid, occupied=300)
