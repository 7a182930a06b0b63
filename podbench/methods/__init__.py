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

Every method is an estimator: keyword-only hyperparameters, ``fit(...) -> self``,
``predict(...) -> (m, n)`` displacement matrix; fitted state ends in ``_``. Every ``fit``
accepts ``basis=`` (an orthonormal ``m × k`` basis used instead of the POMs).
"""

from .base import PODMethod
from .forced import MultipleLoad, SingleLoad
from .free import MDS, POVR
from .mixed import MixedResponse

__all__ = ["PODMethod", "POVR", "MDS", "SingleLoad", "MultipleLoad", "MixedResponse"]
