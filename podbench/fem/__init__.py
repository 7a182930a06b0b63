"""Finite-element builders: beams, the satellite truss, spring–mass chains, user matrices.

Structures are usually loaded from declarative files: ``load_structure("lti_beam")`` reads
``structures/lti_beam.toml`` (see :mod:`podbench.fem.files` and ``docs/structures.md``).
"""

from .beam import beam_element_matrices, cantilever_beam, density_from_lbm_per_ft3
from .files import build_structure, list_structures, load_structure, register_kind
from .laws import ConstantLaw, LinearLaw, SineLaw
from .matrices import from_matrices, read_matrix
from .structure import CubicSpring, NonlinearElement, StiffnessEvent, Structure, VariableMass

__all__ = [
    "Structure",
    "VariableMass",
    "StiffnessEvent",
    "NonlinearElement",
    "CubicSpring",
    "ConstantLaw",
    "SineLaw",
    "LinearLaw",
    "load_structure",
    "build_structure",
    "list_structures",
    "register_kind",
    "cantilever_beam",
    "beam_element_matrices",
    "density_from_lbm_per_ft3",
    "from_matrices",
    "read_matrix",
]
