"""Established identification methods ("peers") in podbench's contract.

=================  ======================================================  ================
Class              Method                                                  Needs
=================  ======================================================  ================
:class:`ERA`       ERA/OKID (Juang & Pappa 1985; Juang et al. 1993)        numpy, scipy
:class:`DMDc`      dynamic mode decomposition with control (Proctor 2016)  PyDMD
:class:`OpInf`     operator inference, linear model with input             opinf
=================  ======================================================  ================

Each is an estimator like the POD methods (:class:`podbench.methods.PODMethod`): it fits on
forced records that start at rest (or on measured inputs, ``inputs="measured"``), works in
an ``m × k`` output/input basis (``modes_``: the POMs of all its training records, or
``basis=``), and chooses its hyperparameter (order,
rank, regularization) by a hold-out rule on the training records only. PyDMD and opinf are
optional: ``pip install 'podbench[peers]'``.
"""

from podbench import _compat
from podbench.sysid.methods.peers.dmd_control import DMDc
from podbench.sysid.methods.peers.era import ERA, ERA_BLOCKS
from podbench.sysid.methods.peers.operator_inference import OpInf

__all__ = ["ERA", "DMDc", "OpInf", "ERA_BLOCKS"]


def __getattr__(name: str):
    """Retired names (:data:`podbench._compat.RETIRED`): ``ERAIO``, ``DMDcIO``, ``OpInfIO``."""
    return _compat.retired(__name__, name)
