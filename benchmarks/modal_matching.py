"""A matching rule of the modal comparison against a study's committed ``modal.csv``.

``podbench.sysid.modal.match_modes`` pairs identified modes with the finite-element modes
by MAC, ties (MACs within ``MAC_TIE``) broken by the nearer frequency
(``rule="mac-frequency"``, what every study writes): SL's and POVR's diagonal kernels give
every pole of a POC that POM's shape, so MAC alone ties between poles of different
frequencies. This runs the study with another rule (``--rule``, default the variant
``"mac"``, MAC alone) into a temporary folder (the checkout's results are not touched) and
prints every ``modal.csv`` row that differs from the committed one, and a count per
method. ``--copies each`` reads a pole the realization holds several times as one mode per
copy (the named variant of ``StateSpaceModel.modes``; the rule merges the copies into one
mode shaped by the residue)::

    python benchmarks/modal_matching.py                 # chapter4, MAC alone
    python benchmarks/modal_matching.py --study peers --cache .podbench_cache
    python benchmarks/modal_matching.py --rule mac-frequency --copies each
"""

from __future__ import annotations

import argparse
import functools
import os
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
if __package__ in (None, ""):
    sys.path.insert(0, str(ROOT))


def main(argv=None) -> int:
    import numpy as np
    import pandas as pd

    import podbench.harness.modal as hm
    from podbench.cli import main as cli
    from podbench.sysid.modal import match_modes
    from podbench.sysid.realize import COPIES_RULES, StateSpaceModel

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--study", default="chapter4")
    ap.add_argument("--cache", default=".podbench_cache")
    ap.add_argument("--rule", default="mac", help="the matching rule to compare")
    ap.add_argument("--copies", default="merge", choices=COPIES_RULES,
                    help="how a pole held several times is read (default the rule, merge)")
    args = ap.parse_args(argv)
    hm.match_modes = functools.partial(match_modes, rule=args.rule)
    StateSpaceModel.modes = functools.partialmethod(StateSpaceModel.modes,
                                                    copies=args.copies)
    with tempfile.TemporaryDirectory() as tmp:
        rc = cli(["run", args.study, "-q", "--jobs", "1", "--no-figures", "--cache",
                  args.cache, "-o", str(Path(tmp) / args.study)])
        if rc:
            return rc
        new = pd.read_csv(Path(tmp) / args.study / "modal.csv")
    old = pd.read_csv(ROOT / "results" / args.study / "modal.csv")
    key = ["scenario", "structure", "method", "mode"]
    both = old.merge(new, on=key, suffixes=("", "_rule"))
    cols = ["identified_frequency_hz", "mac", "status"]
    same = np.ones(len(both), dtype=bool)
    for c in cols:
        a, b = both[c], both[c + "_rule"]
        same &= ((a == b) | (a.isna() & b.isna())).to_numpy()
    changed = both[~same]
    print(f"{args.study}: {len(changed)} of {len(both)} modal.csv rows change with "
          f"rule={args.rule!r}, copies={args.copies!r}")
    if len(changed):
        show = key + ["frequency_hz"] + [c for c in cols for c in (c, c + "_rule")]
        print(changed[show].to_string(index=False))
        print(changed.groupby("method").size().to_string())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
