from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from interbot_core.occupancy_grid import (
    FREE,
    OCCUPIED,
    UNKNOWN,
    MapLoadError,
    OccupancyGrid,
    load_map,
    read_pgm,
    write_pgm,
)


def small_grid() -> OccupancyGrid:
    cells = np.full((4, 6), FREE, dtype=np.int8)
    cells[0, :] = OCCUPIED  # bottom row
    cells[3, 5] = UNKNOWN  # top-right
    return OccupancyGrid(cells, 0.5, -1.0, 2.0)


def test_world_cell_roundtrip_and_orientation() -> None:
    grid = small_grid()
    row, col = grid.world_to_cell(-1.0 + 0.25, 2.0 + 0.25)
    assert (int(row), int(col)) == (0, 0)
    assert grid.cells[int(row), int(col)] == OCCUPIED  # row 0 is at the bottom (lowest y)
    x, y = grid.cell_to_world(3, 5)
    assert (float(x), float(y)) == pytest.approx((-1.0 + 5.5 * 0.5, 2.0 + 3.5 * 0.5))
    assert not grid.is_free(float(x), float(y))
    assert grid.is_free(0.0, 3.0)
    assert not grid.is_free(100.0, 100.0)
    assert grid.size_m == (3.0, 2.0)


def test_save_and_load_roundtrip(tmp_path: Path) -> None:
    grid = small_grid()
    path = grid.save(tmp_path / "m.yaml")
    loaded = load_map(path)
    np.testing.assert_array_equal(loaded.cells, grid.cells)
    assert loaded.resolution == 0.5
    assert (loaded.origin_x, loaded.origin_y) == (-1.0, 2.0)
    # PGM stores the top row first: the occupied bottom row is the last image row.
    image = read_pgm(tmp_path / "m.pgm")
    assert (image[-1] == 0).all() and image[0, 5] == 205


def test_map_server_thresholds_and_negate(tmp_path: Path) -> None:
    image = np.array([[0, 100, 205, 254, 255]], dtype=np.uint8)
    write_pgm(tmp_path / "t.pgm", image)
    (tmp_path / "t.yaml").write_text(
        "image: t.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n"
    )
    # p = (255 - v) / 255 -> 1.0, 0.61, 0.196, 0.004, 0.0
    assert load_map(tmp_path / "t.yaml").cells[0].tolist() == [100, -1, -1, 0, 0]
    (tmp_path / "n.yaml").write_text(
        "image: t.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nnegate: 1\n"
    )
    assert load_map(tmp_path / "n.yaml").cells[0].tolist() == [0, -1, 100, 100, 100]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            "resolution: 0.1\norigin: [0, 0, 0]\n",
            r"bad\.yaml: image is missing \(the document needs image, resolution, origin\)",
        ),
        (
            "image: t.pgm\nresolution: 0.1\norigin: [0, 0]\n",
            r"origin must be an array of 3 elements, got \[0, 0\]",
        ),
        ("image: t.pgm\nresolution: 0.1\norigin: [0, .nan, 0]\n", r"origin\[1\] must be a finite"),
        ("image: t.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nnegate: 2\n", r"negate = 2 is outside"),
        ("[1, 2]\n", r"the document must be an object with keys image, resolution, origin"),
        (
            "image: t.pgm\nresolution: -1\norigin: [0, 0, 0]\n",
            r"resolution = -1 m is outside the allowed range \(0, inf\) m",
        ),
        ("image: nope.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n", "cannot read"),
        (
            "image: t.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nmode: scale\n",
            r"mode must be one of trinary; got 'scale'",
        ),
        ("[1, 2", "invalid YAML"),
    ],
)
def test_bad_map_files_name_the_problem(tmp_path: Path, text: str, message: str) -> None:
    write_pgm(tmp_path / "t.pgm", np.zeros((2, 2), dtype=np.uint8))
    (tmp_path / "bad.yaml").write_text(text)
    with pytest.raises(MapLoadError, match=message):
        load_map(tmp_path / "bad.yaml")


def test_truncated_pgm(tmp_path: Path) -> None:
    (tmp_path / "x.pgm").write_bytes(b"P5\n10 10\n255\n" + bytes(20))
    with pytest.raises(MapLoadError, match="20 bytes but the header says 10x10 = 100"):
        read_pgm(tmp_path / "x.pgm")


def test_pgm_with_more_data_than_its_header_is_refused(tmp_path: Path) -> None:
    (tmp_path / "x.pgm").write_bytes(b"P5\n10 10\n255\n" + bytes(150))
    with pytest.raises(MapLoadError, match=r"x\.pgm: image data is 150 bytes .* = 100"):
        read_pgm(tmp_path / "x.pgm")
    (tmp_path / "y.pgm").write_bytes(b"P2\n2 2\n255\n1 2 3 4 5\n")
    with pytest.raises(MapLoadError, match="5 values but the header says 2x2 = 4"):
        read_pgm(tmp_path / "y.pgm")


@pytest.mark.realdata
def test_real_willow_map(shared_data: Path) -> None:
    grid = load_map(shared_data / "maps" / "willow.yaml")
    assert (grid.width, grid.height) == (1165, 945)
    assert grid.resolution == pytest.approx(0.05)
    frac_free = float((grid.cells == FREE).mean())
    assert 0.2 < frac_free < 0.9
    assert grid.occupied().any() and (grid.cells == UNKNOWN).any()
