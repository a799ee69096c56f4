"""The demo's check of the X11 libraries Qt needs: found by ldd, installed or explained."""

from __future__ import annotations

import pytest

from interbot_cli import system_libs
from interbot_cli.system_libs import SystemLibsError, ensure_xcb_libraries, parse_ldd

# What `ldd libqxcb.so` printed on this project's CI machine before the libraries were installed.
LDD_MISSING = """\
\tlinux-vdso.so.1 (0x00007ffc3a5f2000)
\tlibQt6XcbQpa.so.6 => /x/PySide6/Qt/plugins/platforms/../../lib/libQt6XcbQpa.so.6 (0x1)
\tlibxcb-icccm.so.4 => not found
\tlibxcb-keysyms.so.1 => not found
\tlibxcb-cursor.so.0 => not found
\tlibxcb-icccm.so.4 => not found
\tlibc.so.6 => /lib/x86_64-linux-gnu/libc.so.6 (0x2)
"""
LDD_OK = "\tlibxcb.so.1 => /lib/x86_64-linux-gnu/libxcb.so.1 (0x1)\n"


def test_ldd_output_gives_each_missing_library_once() -> None:
    assert parse_ldd(LDD_MISSING) == (
        "libxcb-icccm.so.4",
        "libxcb-keysyms.so.1",
        "libxcb-cursor.so.0",
    )
    assert parse_ldd(LDD_OK) == ()


def test_missing_libraries_map_to_the_debian_packages() -> None:
    missing = system_libs.packages_for(parse_ldd(LDD_MISSING))
    assert missing.packages == ("libxcb-icccm4", "libxcb-keysyms1", "libxcb-cursor0")
    assert missing.install_command(as_root=False) == (
        "sudo apt-get install -y libxcb-icccm4 libxcb-keysyms1 libxcb-cursor0"
    )


def test_without_root_or_sudo_the_one_command_to_run_is_given() -> None:
    with pytest.raises(SystemLibsError) as exc:
        ensure_xcb_libraries(
            run_ldd=lambda _cmd: LDD_MISSING,
            run_install=lambda _cmd: pytest.fail("must not install without permission"),
            euid=1000,
            has_apt=True,
            sudo_ok=lambda: False,
        )
    assert "sudo apt-get install -y libxcb-icccm4 libxcb-keysyms1 libxcb-cursor0" in str(exc.value)


def test_as_root_it_installs_then_checks_again() -> None:
    installed: list[list[str]] = []
    answers = iter([LDD_MISSING, LDD_OK])
    ensure_xcb_libraries(
        run_ldd=lambda _cmd: next(answers),
        run_install=lambda cmd: installed.append(cmd) or 0,
        euid=0,
        has_apt=True,
    )
    assert installed[0][-2:] == ["update", "-q"]
    assert installed[1][-3:] == ["libxcb-icccm4", "libxcb-keysyms1", "libxcb-cursor0"]
    assert installed[1][:2] == ["env", "DEBIAN_FRONTEND=noninteractive"]


def test_with_passwordless_sudo_it_installs_through_sudo() -> None:
    installed: list[list[str]] = []
    answers = iter([LDD_MISSING, LDD_OK])
    ensure_xcb_libraries(
        run_ldd=lambda _cmd: next(answers),
        run_install=lambda cmd: installed.append(cmd) or 0,
        euid=1000,
        has_apt=True,
        sudo_ok=lambda: True,
    )
    assert all(cmd[:2] == ["sudo", "-n"] for cmd in installed)


def test_a_failed_install_says_what_to_run() -> None:
    with pytest.raises(SystemLibsError, match="apt-get install -y libxcb-icccm4"):
        ensure_xcb_libraries(
            run_ldd=lambda _cmd: LDD_MISSING, run_install=lambda _cmd: 100, euid=0, has_apt=True
        )


def test_nothing_missing_does_nothing() -> None:
    ensure_xcb_libraries(
        run_ldd=lambda _cmd: LDD_OK,
        run_install=lambda _cmd: pytest.fail("nothing to install"),
        euid=1000,
        has_apt=False,
    )


@pytest.mark.parametrize(
    ("env", "xcb"),
    [
        ({"DISPLAY": ":0"}, True),
        ({"DISPLAY": ":0", "WAYLAND_DISPLAY": "wayland-0"}, False),
        ({"QT_QPA_PLATFORM": "offscreen", "DISPLAY": ":0"}, False),
        ({"QT_QPA_PLATFORM": "xcb"}, True),
        ({}, False),
    ],
)
def test_only_the_x11_platform_is_checked(env: dict[str, str], xcb: bool) -> None:
    assert system_libs.uses_xcb(env) is xcb


def test_the_real_plugin_is_found_and_checked() -> None:
    """On this machine: the wheel's plugin exists and ldd's answer parses (whatever it says)."""
    assert system_libs.xcb_plugin() is not None
    missing = system_libs.missing_xcb_libraries()
    assert not missing.unknown, f"sonames with no Debian package in the table: {missing.unknown}"
