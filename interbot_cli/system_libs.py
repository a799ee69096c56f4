"""The system libraries Qt's X11 (xcb) platform plugin needs, found and installed before the demo.

PySide6 wheels bundle Qt but not the X11 client libraries its ``xcb`` plugin links against. On a
bare Debian image several are missing (``libxcb-cursor0``, ``libxcb-icccm4``,
``libxcb-keysyms1``, ...) and every Qt program then aborts with a core dump at start-up. So the
demo asks the dynamic linker first: ``ldd`` on the plugin lists each library it cannot resolve as
``=> not found``. Those sonames map to Debian packages; as root (or with passwordless sudo) they
are installed, otherwise the one exact command to run is printed and the demo stops there.

Only the xcb plugin is checked: offscreen, minimal and Wayland sessions need none of it.
"""

from __future__ import annotations

import logging
import os
import re
import shutil
import subprocess
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

logger = logging.getLogger(__name__)

# soname -> Debian (bookworm) package. Every library libqxcb.so and its Qt dependencies link
# against that a minimal Debian image lacks; `apt-file search <soname>` gives the same answers.
DEBIAN_PACKAGES: dict[str, str] = {
    "libxcb-cursor.so.0": "libxcb-cursor0",
    "libxcb-icccm.so.4": "libxcb-icccm4",
    "libxcb-keysyms.so.1": "libxcb-keysyms1",
    "libxcb-image.so.0": "libxcb-image0",
    "libxcb-render-util.so.0": "libxcb-render-util0",
    "libxcb-shape.so.0": "libxcb-shape0",
    "libxcb-randr.so.0": "libxcb-randr0",
    "libxcb-render.so.0": "libxcb-render0",
    "libxcb-shm.so.0": "libxcb-shm0",
    "libxcb-sync.so.1": "libxcb-sync1",
    "libxcb-xfixes.so.0": "libxcb-xfixes0",
    "libxcb-xinerama.so.0": "libxcb-xinerama0",
    "libxcb-xkb.so.1": "libxcb-xkb1",
    "libxcb-xinput.so.0": "libxcb-xinput0",
    "libxcb-util.so.1": "libxcb-util1",
    "libxcb.so.1": "libxcb1",
    "libX11-xcb.so.1": "libx11-xcb1",
    "libX11.so.6": "libx11-6",
    "libxkbcommon.so.0": "libxkbcommon0",
    "libxkbcommon-x11.so.0": "libxkbcommon-x11-0",
    "libfontconfig.so.1": "libfontconfig1",
    "libfreetype.so.6": "libfreetype6",
    "libdbus-1.so.3": "libdbus-1-3",
    "libEGL.so.1": "libegl1",
    "libGL.so.1": "libgl1",
    "libOpenGL.so.0": "libopengl0",
    "libGLX.so.0": "libglx0",
    "libglib-2.0.so.0": "libglib2.0-0",
    "libgthread-2.0.so.0": "libglib2.0-0",
    "libICE.so.6": "libice6",
    "libSM.so.6": "libsm6",
}

_NOT_FOUND = re.compile(r"^\s*(\S+)\s+=>\s+not found\s*$")


class SystemLibsError(RuntimeError):
    """The libraries are missing and could not be installed (the message says what to run)."""


@dataclass(frozen=True)
class Missing:
    """What the xcb plugin cannot load, as sonames and as the Debian packages that provide them."""

    sonames: tuple[str, ...]
    packages: tuple[str, ...]
    unknown: tuple[str, ...]  # sonames with no package in the table

    def install_command(self, as_root: bool) -> str:
        prefix = "" if as_root else "sudo "
        return f"{prefix}apt-get install -y " + " ".join(self.packages)


def parse_ldd(output: str) -> tuple[str, ...]:
    """The sonames ``ldd`` reports as ``=> not found``, in order, each once."""
    found: dict[str, None] = {}
    for line in output.splitlines():
        match = _NOT_FOUND.match(line)
        if match:
            found.setdefault(match.group(1), None)
    return tuple(found)


def packages_for(sonames: Sequence[str]) -> Missing:
    """Map sonames to Debian packages; sonames not in the table are kept as ``unknown``."""
    packages: dict[str, None] = {}
    unknown = []
    for soname in sonames:
        package = DEBIAN_PACKAGES.get(soname)
        if package is None:
            unknown.append(soname)
        else:
            packages.setdefault(package, None)
    return Missing(tuple(sonames), tuple(packages), tuple(unknown))


def xcb_plugin() -> Path | None:
    """Path of PySide6's ``libqxcb.so``, or None if this PySide6 has no xcb plugin."""
    import PySide6

    plugin = Path(PySide6.__file__).parent / "Qt" / "plugins" / "platforms" / "libqxcb.so"
    return plugin if plugin.is_file() else None


def uses_xcb(environ: dict[str, str] | os._Environ[str] = os.environ) -> bool:
    """True when Qt will pick its X11 plugin: an explicit ``xcb``, or a DISPLAY and no Wayland."""
    platform = environ.get("QT_QPA_PLATFORM", "")
    if platform:
        return platform.startswith("xcb")
    return bool(environ.get("DISPLAY")) and not environ.get("WAYLAND_DISPLAY")


def missing_xcb_libraries(
    run: Callable[[list[str]], str] | None = None, plugin: Path | None = None
) -> Missing:
    """Ask the dynamic linker which libraries the xcb plugin lacks (empty when all resolve)."""
    plugin = plugin or xcb_plugin()
    if plugin is None or shutil.which("ldd") is None:
        return Missing((), (), ())
    runner = run or _run_ldd
    return packages_for(parse_ldd(runner(["ldd", str(plugin)])))


def _run_ldd(cmd: list[str]) -> str:
    result = subprocess.run(cmd, capture_output=True, text=True, check=False, timeout=30)
    return result.stdout


def can_install_as(euid: int, has_apt: bool, sudo_ok: Callable[[], bool]) -> str | None:
    """``""`` when root, ``"sudo"`` when passwordless sudo works, None when we cannot install."""
    if not has_apt:
        return None
    if euid == 0:
        return ""
    return "sudo" if sudo_ok() else None


def _passwordless_sudo() -> bool:
    if shutil.which("sudo") is None:
        return False
    probe = subprocess.run(["sudo", "-n", "true"], capture_output=True, check=False, timeout=10)
    return probe.returncode == 0


def ensure_xcb_libraries(
    *,
    run_ldd: Callable[[list[str]], str] | None = None,
    run_install: Callable[[list[str]], int] | None = None,
    euid: int | None = None,
    has_apt: bool | None = None,
    sudo_ok: Callable[[], bool] = _passwordless_sudo,
) -> None:
    """Install what the xcb plugin lacks when this user may; else raise with the exact command.

    Raises `SystemLibsError` with the one command to run (or the unknown sonames) when the
    libraries stay missing. Installing runs ``apt-get update`` then ``apt-get install -y``
    non-interactively, as root or through ``sudo -n``.
    """
    missing = missing_xcb_libraries(run_ldd)
    if not missing.sonames:
        return
    uid = os.geteuid() if euid is None else euid
    apt = shutil.which("apt-get") is not None if has_apt is None else has_apt
    how = can_install_as(uid, apt, sudo_ok)
    if missing.unknown:
        raise SystemLibsError(
            "Qt's X11 plugin cannot load "
            + ", ".join(missing.unknown)
            + " and no Debian package is known for it; install the package that provides it"
            + (f" (and: {missing.install_command(uid == 0)})" if missing.packages else "")
        )
    if how is None:
        raise SystemLibsError(
            "Qt's X11 plugin needs system libraries that are missing ("
            + ", ".join(missing.sonames)
            + "). Run this once, then `make demo` again:\n    "
            + missing.install_command(as_root=False)
        )
    installer = run_install or _run_install
    prefix = ["sudo", "-n"] if how == "sudo" else []
    logger.warning("installing the X11 libraries Qt needs: %s", " ".join(missing.packages))
    env_cmd = ["env", "DEBIAN_FRONTEND=noninteractive"]
    if (
        installer([*prefix, *env_cmd, "apt-get", "update", "-q"]) != 0
        or installer([*prefix, *env_cmd, "apt-get", "install", "-y", "-q", *missing.packages]) != 0
    ):
        raise SystemLibsError(
            "installing the X11 libraries Qt needs failed; run:\n    "
            + missing.install_command(as_root=uid == 0)
        )
    still = missing_xcb_libraries(run_ldd)
    if still.sonames:
        raise SystemLibsError(
            "after installing, Qt's X11 plugin still cannot load " + ", ".join(still.sonames)
        )


def _run_install(cmd: list[str]) -> int:
    return subprocess.run(cmd, check=False).returncode
