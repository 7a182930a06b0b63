"""POD-based identification methods of Allison (2007), Chapter 3 (Table 3.1).

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
``fit(records, *, basis=None) -> self`` over records (``W, F, w0, v0, dt``:
:class:`podbench.Record` or :class:`podbench.Response`), ``predict(record) -> (m, n)``
displacement matrix; fitted state ends in ``_``; ``basis=`` replaces the POMs by a given
orthonormal ``m × k`` basis. The dissertation's array forms (``POVR().fit(W, x0)``,
``MultipleLoad().fit([W…], [F…], dt=…)``) remain as thin wrappers.

The peers (:mod:`podbench.methods.peers`: :class:`ERA` (ERA/OKID), :class:`DMDc`,
:class:`OpInf`) are established identification methods in the same contract.
"""

from podbench.sysid.methods.base import PODMethod
from podbench.sysid.methods.forced import MultipleLoad, SingleLoad
from podbench.sysid.methods.free import MDS, POVR
from podbench.sysid.methods.mixed import MixedResponse
from podbench.sysid.methods.peers import ERA, DMDc, OpInf
from podbench.sysid.methods.superposition import Superposition

BUILTIN_METHODS = {"POVR": POVR, "MDS": MDS, "SL": SingleLoad, "ML": MultipleLoad,
                   "MR": MixedResponse, "ERA": ERA, "DMDc": DMDc, "OpInf": OpInf}
"""The names a scenario file may give as ``method`` (besides ``superposition`` and a user's
``module:Class``), with their classes; ERA, DMDc and OpInf are the peers
(:mod:`podbench.methods.peers`; DMDc and OpInf need ``pip install 'podbench[peers]'``)."""

__all__ = ["PODMethod", "POVR", "MDS", "SingleLoad", "MultipleLoad", "MixedResponse",
           "Superposition", "ERA", "DMDc", "OpInf", "BUILTIN_METHODS"]
