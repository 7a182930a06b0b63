"""POD-based identification methods of Allison (2007), Chapter 3 (Table 3.1), and their peers.

======================  ==============  =====================  ====  ===========================
Class                   Abbreviation    Excitation             NDS   Assumption (besides linear)
======================  ==============  =====================  ====  ===========================
:class:`POVR`           POVR            initial conditions     1     diagonal Φ11 or Φ12
:class:`MDS`            MDS             initial conditions     k     none
:class:`SingleLoad`     SL              loads                  1     diagonal C(t)
:class:`MultipleLoad`   ML              loads                  k     none
:class:`MixedResponse`  MR              both                   3     diagonal C, Φ11, Φ12
======================  ==============  =====================  ====  ===========================

Every method is an estimator (:class:`PODMethod`): keyword-only hyperparameters,
``fit(records, *, basis=None) -> self`` over records (:class:`podbench.Record`: inputs and
outputs with their units; the dissertation's ``W, F, w0, v0, dt`` is the case "forces at the
output sensors"), ``predict(record, *, coverage=None)``; fitted state ends in ``_``;
``basis=`` replaces the POMs by a given orthonormal ``m × k`` basis. ML also takes measured
inputs that are not at the outputs (Chapter 6; SL and MR refuse them, with the reason);
:class:`FIRLeastSquares` is its baseline without the POD. The dissertation's array forms
(``POVR().fit(W, x0)``, ``MultipleLoad().fit([W…], [F…], dt=…)``) are read into records by
:mod:`podbench.sysid.methods.arrays`.

The peers (:mod:`podbench.methods.peers`: :class:`ERA` (ERA/OKID), :class:`DMDc`,
:class:`OpInf`; :class:`Mdof`, mdof's OKID-ERA and SRIM) are established identification
methods in the same contract. The names a scenario file, ``podbench predict`` and
``podbench methods`` take are in :mod:`podbench.sysid.registry`.
"""

from podbench import _compat
from podbench.sysid.methods.base import PODMethod
from podbench.sysid.methods.fir import FIRLeastSquares
from podbench.sysid.methods.forced import MultipleLoad, SingleLoad
from podbench.sysid.methods.free import MDS, POVR
from podbench.sysid.methods.mdof_peer import Mdof
from podbench.sysid.methods.mixed import MixedResponse
from podbench.sysid.methods.peers import ERA, DMDc, OpInf
from podbench.sysid.methods.superposition import Superposition

__all__ = ["PODMethod", "POVR", "MDS", "SingleLoad", "MultipleLoad", "MixedResponse",
           "Superposition", "FIRLeastSquares", "ERA", "DMDc", "OpInf", "Mdof",
           "BUILTIN_METHODS"]


def __getattr__(name: str):
    """``BUILTIN_METHODS`` (:data:`podbench.sysid.registry.BUILTIN_METHODS`) and the retired
    names (:data:`podbench._compat.RETIRED`): ``MultipleLoadIO`` …"""
    return _compat.retired(__name__, name)
