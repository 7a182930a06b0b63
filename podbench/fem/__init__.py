"""Finite-element builders: beams, the satellite truss, spring–mass chains, user matrices."""

from .structure import CubicSpring, NonlinearElement, StiffnessEvent, Structure, VariableMass

__all__ = ["Structure", "VariableMass", "StiffnessEvent", "NonlinearElement", "CubicSpring"]
