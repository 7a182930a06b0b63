"""Command-line interface (``podbench``). Subcommands are added by the harness."""

from __future__ import annotations

import sys


def main(argv=None) -> int:
    print("podbench: the study harness is not built yet", file=sys.stderr)
    return 2


if __name__ == "__main__":
    raise SystemExit(main())
