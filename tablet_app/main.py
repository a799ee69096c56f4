"""Entry point of `interbot-tablet`."""

from __future__ import annotations

import sys
from collections.abc import Sequence


def main(argv: Sequence[str] | None = None) -> int:
    print(
        "interbot-tablet: not built yet: the Tablet (issue 6) does not exist in this version.",
        file=sys.stderr,
    )
    return 3


if __name__ == "__main__":
    sys.exit(main())
