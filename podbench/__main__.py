"""``python -m podbench``: the same command line as ``podbench``."""

import sys

from podbench.cli import main

if __name__ == "__main__":
    sys.exit(main())
