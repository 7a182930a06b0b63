"""podbench: a benchmark suite for structural system identification with the POD.

The science is T. C. Allison, *System Identification via the Proper Orthogonal
Decomposition*, PhD dissertation, Virginia Tech, 2007. Units are inch, lbf, second.

Quick tour::

    import podbench as pb
    s = pb.load_structure("lti_beam")                 # structures/lti_beam.toml
    w0 = pb.excitations.static_displacement(s, [(24.0, 1.0)])
    r = pb.simulate(s, n_samples=500, dt=1e-4, initial_displacement=w0)
    from podbench.methods import POVR            # podbench.sysid.methods
    model = POVR(n_modes=3).fit(r)                    # a Response is a record (W, F, w0, v0, dt)
    W_hat = model.predict(pb.Record(W=r.W, w0=0.5 * r.w0))   # the response to half of w0

    res = pb.run("chapter4", figures=False)           # as `podbench run chapter4`
    res.summary                                       # results/chapter4/summary.csv
"""

from podbench import _compat, errors
from podbench.api import StudyResult, fit, load_model, run
from podbench.core.records import Record
from podbench.core.response import Response, displacement_norm, norm_percent_error
from podbench.core.version import __version__ as __version__
from podbench.dynamics import excitations, simulate
from podbench.structures import list_structures, load_structure
from podbench.structures.structure import Structure
from podbench.sysid import deconvolution, methods, pod

_compat.install()

__all__ = [
    "run",
    "StudyResult",
    "fit",
    "load_model",
    "Record",
    "Response",
    "Structure",
    "deconvolution",
    "displacement_norm",
    "errors",
    "excitations",
    "list_structures",
    "load_structure",
    "methods",
    "norm_percent_error",
    "pod",
    "simulate",
]
