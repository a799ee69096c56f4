from __future__ import annotations

import pytest

from interbot_core.screen_layout import (
    LayoutError,
    Rect,
    layout,
    parse_geometry,
    parse_screens,
)


def overlap(a: Rect, b: Rect) -> bool:
    return a.x < b.x + b.w and b.x < a.x + a.w and a.y < b.y + b.h and b.y < a.y + a.h


@pytest.mark.parametrize("size", [(1920, 1080), (1280, 800), (2560, 1600), (1024, 768)])
def test_one_screen_side_by_side_without_overlap(size: tuple[int, int]) -> None:
    screen = Rect(0, 0, *size)
    where = layout([screen])
    assert where.tablet_screen is None
    assert not overlap(where.station, where.tablet)
    for rect in (where.station, where.tablet):
        assert rect.x >= 0 and rect.y >= 0
        assert rect.x + rect.w <= screen.w and rect.y + rect.h <= screen.h
    assert where.tablet.w / where.tablet.h == pytest.approx(16 / 10, rel=0.01)
    assert where.station.w + where.tablet.w == screen.w


def test_two_screens_tablet_full_screen_on_the_second() -> None:
    where = layout([Rect(0, 0, 1920, 1080), Rect(1920, 0, 1280, 800)])
    assert where.station == Rect(0, 0, 1920, 1080)
    assert where.tablet == Rect(1920, 0, 1280, 800)
    assert where.tablet_screen == 1


def test_geometry_and_screen_list_parse_and_refuse_nonsense() -> None:
    assert parse_geometry("10,20,300,200") == Rect(10, 20, 300, 200)
    assert parse_screens("[[0, 0, 800, 600]]") == [Rect(0, 0, 800, 600)]
    for bad in ("1,2,3", "a,b,c,d", "0,0,0,10"):
        with pytest.raises(LayoutError):
            parse_geometry(bad)
    for bad in ("{}", "[[0, 0, 800]]", "nope", "[[0, 0, 1.5, 2]]"):
        with pytest.raises(LayoutError):
            parse_screens(bad)
    with pytest.raises(LayoutError):
        layout([])
