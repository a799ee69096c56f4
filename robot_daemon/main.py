"""Entry point of `interbot-daemon`."""

from __future__ import annotations

import sys
from collections.abc import Sequence


def main(argv: Sequence[str] | None = None) -> int:
    print(
        "interbot-daemon: not built yet: the robot daemon (issue 4) does not exist in this version.",
        file=sys.stderr,
    )
    return 3


if __name__ == "__main__":
    sys.exit(main())
