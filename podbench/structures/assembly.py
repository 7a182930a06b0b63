"""Assembly of a parent structure and a component that share interface DOFs (Chapter 6's truth).

``attach(parent, component, parent_dofs, component_dofs)`` merges component DOF
``component_dofs[i]`` into parent DOF ``parent_dofs[i]`` (a rigid connection: the two
displacements are one unknown) and appends the component's other DOFs after the parent's.
The assembled ``M``, ``C``, ``K`` are the sums of the two structures' matrices scattered to
the merged numbering; the sensors are the parent's. This is the reference that
:mod:`podbench.dynamics.coupling` must reproduce when it couples the parent with the
component's exact kernel.

Units: inch, lbf, second.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from podbench.errors import InputError
from podbench.structures.structure import Structure

__all__ = ["attach", "merged_numbering"]


def merged_numbering(n_parent: int, n_component: int, parent_dofs, component_dofs) -> np.ndarray:
    """Index in the assembled structure of every component DOF, (n_component,) ints."""
    pd_ = np.asarray(parent_dofs, dtype=np.int64).ravel()
    cd = np.asarray(component_dofs, dtype=np.int64).ravel()
    if pd_.size != cd.size or pd_.size == 0:
        raise InputError(f"attach: parent_dofs and component_dofs must pair up, got "
                         f"{pd_.tolist()} and {cd.tolist()}")
    if pd_.min() < 0 or pd_.max() >= n_parent or cd.min() < 0 or cd.max() >= n_component:
        raise InputError(f"attach: interface DOFs out of range (parent {n_parent} DOFs, "
                         f"component {n_component} DOFs)")
    if np.unique(pd_).size != pd_.size or np.unique(cd).size != cd.size:
        raise InputError("attach: repeated interface DOFs")
    idx = np.full(n_component, -1, dtype=np.int64)
    idx[cd] = pd_
    rest = np.flatnonzero(idx < 0)
    idx[rest] = n_parent + np.arange(rest.size)
    return idx


def _scatter(A: sp.spmatrix, idx: np.ndarray, n: int) -> sp.csr_matrix:
    A = sp.coo_matrix(A)
    return sp.csr_matrix((A.data, (idx[A.row], idx[A.col])), shape=(n, n))


def attach(parent: Structure, component: Structure, parent_dofs, component_dofs, *,
           name: str | None = None) -> Structure:
    """The parent with the component rigidly attached at the interface DOFs.

    Both structures must be linear and time-invariant (the assembled model of a
    time-varying component is built by its own file, e.g. ``ltv_beam``).
    """
    for s in (parent, component):
        if not (s.is_linear and s.is_time_invariant):
            raise InputError(f"attach: {s.name!r} is nonlinear or time-varying; only linear "
                             "time-invariant structures are assembled here")
    idx = merged_numbering(parent.n_dofs, component.n_dofs, parent_dofs, component_dofs)
    n = parent.n_dofs + component.n_dofs - np.asarray(parent_dofs).size
    grow = sp.csr_matrix((n, n))

    def pad(A):
        A = sp.coo_matrix(A)
        return sp.csr_matrix((A.data, (A.row, A.col)), shape=(n, n))

    M = pad(parent.M) + _scatter(component.M, idx, n)
    K = pad(parent.K) + _scatter(component.K, idx, n)
    C = grow
    if parent.C is not None:
        C = C + pad(parent.C)
    if component.C is not None:
        C = C + _scatter(component.C, idx, n)
    return Structure(
        name=name or f"{parent.name}+{component.name}", M=M, K=K,
        C=C if C.nnz else None, sensor_dofs=parent.sensor_dofs,
        sensor_positions=parent.sensor_positions, sensor_labels=parent.sensor_labels,
        description=f"{parent.name} with {component.name} attached at parent DOFs "
                    f"{list(np.ravel(parent_dofs))}")
