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

import importlib

from podbench import _compat, errors
from podbench.core.version import __version__ as __version__

_compat.install()

_LAZY = {
    "run": "podbench.api", "StudyResult": "podbench.api", "fit": "podbench.api",
    "load_model": "podbench.api",
    "Record": "podbench.core.records",
    "Response": "podbench.core.response", "displacement_norm": "podbench.core.response",
    "norm_percent_error": "podbench.core.response",
    "excitations": "podbench.dynamics", "simulate": "podbench.dynamics",
    "list_structures": "podbench.structures", "load_structure": "podbench.structures",
    "Structure": "podbench.structures.structure",
    "deconvolution": "podbench.sysid", "methods": "podbench.sysid", "pod": "podbench.sysid",
}
"""Public name → the module it comes from, imported on first use (PEP 562): ``import
podbench`` and the command line's ``--help`` do not pay for SciPy, pandas or Matplotlib."""


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'podbench' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


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
