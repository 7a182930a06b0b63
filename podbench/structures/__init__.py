"""Finite-element builders: beams, the satellite truss, spring–mass chains, user matrices.

Structures are usually loaded from declarative files: ``load_structure("lti_beam")`` reads
``structures/lti_beam.toml`` (see :mod:`podbench.fem.files` and ``docs/structures.md``).
"""

from podbench.structures.beam import (
    beam_element_matrices,
    cantilever_beam,
    density_from_lbm_per_ft3,
)
from podbench.structures.chain import chain
from podbench.structures.files import (
    build_structure,
    list_structures,
    load_structure,
    register_kind,
)
from podbench.structures.laws import ConstantLaw, LinearLaw, SineLaw
from podbench.structures.matrices import from_matrices, read_matrix
from podbench.structures.structure import (
    CubicSpring,
    NonlinearElement,
    OneSidedSpring,
    StiffnessEvent,
    Structure,
    VariableMass,
)
from podbench.structures.truss import TubeSection, face_dof, satellite_truss, truss_dof

__all__ = [
    "Structure",
    "VariableMass",
    "StiffnessEvent",
    "NonlinearElement",
    "CubicSpring",
    "OneSidedSpring",
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
    "chain",
    "satellite_truss",
    "TubeSection",
    "truss_dof",
    "face_dof",
    "from_matrices",
    "read_matrix",
]
