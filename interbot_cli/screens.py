"""``python -m interbot_cli.screens``: print the screens' geometries as JSON, for the demo launcher.

Run in its own process so the launcher itself never loads Qt: ``[[x, y, w, h], ...]``, the
primary screen first, in Qt's virtual-desktop coordinates (``QScreen.geometry``).
"""

from __future__ import annotations

import json
import sys


def main() -> int:
    from PySide6.QtGui import QGuiApplication

    app = QGuiApplication.instance() or QGuiApplication(sys.argv[:1])
    primary = app.primaryScreen()
    screens = [primary, *(s for s in app.screens() if s is not primary)]
    rects = [[g.x(), g.y(), g.width(), g.height()] for g in (s.geometry() for s in screens)]
    print(json.dumps(rects))
    return 0


if __name__ == "__main__":
    sys.exit(main())
