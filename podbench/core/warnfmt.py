"""podbench's warnings on one line, ``podbench: warning: <message>``, without the Python
source path and code line that :mod:`warnings` shows by default (the command line and its
worker processes install it; other warnings keep the default format)."""

from __future__ import annotations

import sys
import warnings

from podbench.errors import PodbenchWarning

__all__ = ["one_line_warnings"]

_default_show = warnings.showwarning


def one_line_warnings(prefix: str = "podbench") -> None:
    """Show every :class:`~podbench.errors.PodbenchWarning` as ``<prefix>: warning: <message>``."""

    def show(message, category, filename, lineno, file=None, line=None):
        if issubclass(category, PodbenchWarning):
            stream = file if file is not None else sys.stderr
            text = " ".join(str(message).split())
            try:
                print(f"{prefix}: warning: {text}", file=stream, flush=True)
            except OSError:  # pragma: no cover - a closed stderr
                pass
        else:
            _default_show(message, category, filename, lineno, file, line)

    warnings.showwarning = show
