"""Make scenarios/painter_street/data/ from the shared Painter Street records.

Usage: python tools/bundle_painter_street.py SHARED_DIR
(SHARED_DIR: the folder with the 14 CESMD-derived .npz files, events.csv and README.md).

Each bundled .npz keeps what the study reads, with units written into it: ``inputs``
(channels 3, 17, 20), ``outputs`` (7, 9, 4), ``ground`` (every ground-level channel: 1, 2,
3, 15, 16, 17, 18, 19, 20), ``dt``, channel names and units (m/s², as the shared README
states). Values are the shared float32 samples, unchanged. README.md, events.csv and the
BSD 2-Clause notice travel with them.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import numpy as np

GROUND = (1, 2, 3, 15, 16, 17, 18, 19, 20)
LICENSE = """BSD 2-Clause License

Copyright (c) 2023, Chrystal Chern

Redistribution and use in source and binary forms, with or without
modification, are permitted provided that the following conditions are met:

1. Redistributions of source code must retain the above copyright notice, this
   list of conditions and the following disclaimer.

2. Redistributions in binary form must reproduce the above copyright notice,
   this list of conditions and the following disclaimer in the documentation
   and/or other materials provided with the distribution.

THIS SOFTWARE IS PROVIDED BY THE COPYRIGHT HOLDERS AND CONTRIBUTORS "AS IS"
AND ANY EXPRESS OR IMPLIED WARRANTIES, INCLUDING, BUT NOT LIMITED TO, THE
IMPLIED WARRANTIES OF MERCHANTABILITY AND FITNESS FOR A PARTICULAR PURPOSE ARE
DISCLAIMED. IN NO EVENT SHALL THE COPYRIGHT HOLDER OR CONTRIBUTORS BE LIABLE
FOR ANY DIRECT, INDIRECT, INCIDENTAL, SPECIAL, EXEMPLARY, OR CONSEQUENTIAL
DAMAGES (INCLUDING, BUT NOT LIMITED TO, PROCUREMENT OF SUBSTITUTE GOODS OR
SERVICES; LOSS OF USE, DATA, OR PROFITS; OR BUSINESS INTERRUPTION) HOWEVER
CAUSED AND ON ANY THEORY OF LIABILITY, WHETHER IN CONTRACT, STRICT LIABILITY,
OR TORT (INCLUDING NEGLIGENCE OR OTHERWISE) ARISING IN ANY WAY OUT OF THE USE
OF THIS SOFTWARE, EVEN IF ADVISED OF THE POSSIBILITY OF SUCH DAMAGE.
"""
NOTE = """
## In podbench (scenarios/painter_street/data/)

The bundled files are the shared files above reduced to what `podbench run painter_street`
reads, samples unchanged (float32, m/s²): `inputs` (channels 3, 17, 20), `outputs`
(7, 9, 4), `ground` (every ground-level channel 1, 2, 3, 15, 16, 17, 18, 19, 20; none is
missing in these events), `dt`, `input_channels`, `output_channels`, `ground_channels`,
`input_units` = `output_units` = `ground_units` = "m/s^2", `input_quantity` =
`output_quantity` = "acceleration", `event_id`. Made by `tools/bundle_painter_street.py`.
The license notice of the repository the records were obtained from is in LICENSE.md.
"""


def main(src: str, dst: str) -> None:
    src, dst = Path(src), Path(dst)
    dst.mkdir(parents=True, exist_ok=True)
    for f in sorted(src.glob("*.npz")):
        with np.load(f, allow_pickle=False) as z:
            ids = [int(i) for i in z["all_channel_ids"]]
            present = dict(zip(ids, z["channel_present"], strict=True))
            missing = [c for c in GROUND if not present[c]]
            if missing:
                raise SystemExit(f"{f.name}: ground channel(s) {missing} missing")
            ground = np.stack([z["all_channels"][ids.index(c)] for c in GROUND])
            np.savez_compressed(
                dst / f.name, inputs=z["inputs"], outputs=z["outputs"], ground=ground,
                dt=z["dt"], input_channels=z["input_channels"].astype(str),
                output_channels=z["output_channels"].astype(str),
                ground_channels=np.array([str(c) for c in GROUND]),
                input_units=np.array("m/s^2"), output_units=np.array("m/s^2"),
                ground_units=np.array("m/s^2"), input_quantity=np.array("acceleration"),
                output_quantity=np.array("acceleration"), event_id=z["event_id"])
    shutil.copy(src / "events.csv", dst / "events.csv")
    (dst / "README.md").write_text((src / "README.md").read_text() + NOTE)
    (dst / "LICENSE.md").write_text(LICENSE)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2] if len(sys.argv) > 2 else
         str(Path(__file__).resolve().parents[1] / "scenarios/painter_street/data"))
