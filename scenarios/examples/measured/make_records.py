"""Write the example measured records of measured_chain.toml: the coupled chain
(structures/chain_coupled.toml) under six loads, simulated by podbench, with 1 % noise per
measured channel (podbench.noise), one case per file in each supported format.

Run from the repository root: ``python scenarios/examples/measured/make_records.py``.
The records stand in for a laboratory's files; podbench reads them like any measurement.
"""

from pathlib import Path

from podbench.dynamics import simulate
from podbench.dynamics.excitations import Pulse
from podbench.structures import load_structure
from podbench.sysid.measured import write_record
from podbench.sysid.noise import NoiseSpec, noisy

HERE = Path(__file__).resolve().parent
N, DT = 120, 0.004
# case -> (DOF loaded, amplitude lbf, duration s, shape, file format)
CASES = {
    "f1": (4, 1.0, 0.02, "rectangular", "npz"),
    "f2": (3, 1.0, 0.02, "rectangular", "mat"),
    "f3": (2, 1.0, 0.02, "rectangular", "csv"),
    "f4": (1, 1.0, 0.02, "rectangular", "uff"),
    "f5": (0, 1.0, 0.02, "rectangular", "npz"),
    "f6": (2, 2.0, 0.06, "half_sine", "csv"),
}


def main() -> None:
    s = load_structure("chain_coupled")
    labels = [f"x{i}" for i in range(s.n_sensors)]
    for name, (dof, amp, dur, shape, fmt) in CASES.items():
        force = Pulse(dof, amp, dur, shape=shape, by="dof").sample(s, N, DT)
        r = simulate(s, n_samples=N, dt=DT, force=force, label=name)
        m = noisy(r, NoiseSpec(0.01, seed=0), "measured_chain", "chain_coupled", name)
        write_record(HERE / "data" / f"{name}.{fmt}", m, sensors=labels)


if __name__ == "__main__":
    main()
