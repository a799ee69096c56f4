"""Entry point of `interbot-base-station`."""

from __future__ import annotations

import sys
from collections.abc import Sequence


def main(argv: Sequence[str] | None = None) -> int:
    print(
        "interbot-base-station: not built yet: the Base Station (issue 5) does not exist in this version.",
        file=sys.stderr,
    )
    return 3


if __name__ == "__main__":
    sys.exit(main())
