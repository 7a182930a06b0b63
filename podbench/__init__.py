"""podbench: a benchmark suite for structural system identification with the POD.

The science is T. C. Allison, *System Identification via the Proper Orthogonal
Decomposition*, PhD dissertation, Virginia Tech, 2007. Units are inch, lbf, second.
"""

from . import errors
from .data import Response, displacement_norm, norm_percent_error
from .fem.structure import Structure

__version__ = "0.1.0"

__all__ = [
    "Response",
    "Structure",
    "displacement_norm",
    "norm_percent_error",
    "errors",
]
