"""Draw docs/img/band_example.png: one prediction with its 90 % band (issue 21).

ML (6 load cases, 4 modes, cgls) on the LTV beam with 1 % per-channel noise in the training
records, predicting a double hit at 8 in (the calibration study's `double8`); the tip
sensor's displacement, the band and the noise-free truth. Run from the checkout:

    PYTHONPATH=. python docs/band_figure.py
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from podbench.methods import MultipleLoad  # noqa: E402
from podbench.noise import NoiseSpec  # noqa: E402

from podbench.harness.runner import TruthCache, _Truth, load_scenario, resolve_structure  # noqa: E402

root = Path(__file__).resolve().parent
sc = load_scenario(root.parent / "scenarios/calibration/beam_forced.toml")
truth = _Truth(sc, resolve_structure("ltv_beam", sc), TruthCache(root.parent / ".podbench_cache"),
               sc.engine, NoiseSpec(0.01))
train = [truth.train(c) for c in ("l2", "l6", "l10", "l14", "l18", "l22")]
target = truth.get("double8")
model = MultipleLoad(n_modes=4, solver="cgls").fit(train)
p = model.predict(target, coverage=0.9)
i = p.mean.shape[0] - 1  # the tip sensor
t = 1e3 * np.arange(p.mean.shape[1]) * sc.dt
fig, ax = plt.subplots(figsize=(9, 4))
ax.fill_between(t, p.lower[i], p.upper[i], color="tab:blue", alpha=0.25, lw=0,
                label="90 % band")
ax.plot(t, p.mean[i], color="tab:blue", lw=1.4, label="ML prediction")
ax.plot(t, target.W[i], color="black", lw=1.0, ls="--", label="truth (noise-free)")
total = np.linalg.norm(p.mean - target.W) / np.linalg.norm(target.W)
ax.set_title(f"LTV beam, double hit at 8 in, tip sensor: error_estimate "
             f"{p.error_estimate:.3f}, realized total error {total:.3f}, coverage "
             f"{p.covers(target.W):.2f}", fontsize=9)
ax.set_xlabel("time, ms")
ax.set_ylabel("displacement, in")
ax.grid(True, alpha=0.3)
ax.legend(fontsize=8)
fig.tight_layout()
fig.savefig(root / "img" / "band_example.png", dpi=100)
print(f"estimate {p.error_estimate:.4f} realized {total:.4f} coverage {p.covers(target.W):.3f}")
