"""Make the README's pictures of the study report from the real page, in headless Chromium.

Usage: python tools/report_images.py [--report PATH] [--out docs/img]

Without ``--report`` it runs ``podbench run chapter4 -q`` in an empty temporary folder first
(a few minutes: a cold cache; the checkout's results/ are not touched). From that
``report.html`` it writes:

* ``report.png``: the top of the page as a browser shows it at 1280 px (header, table of
  contents and the summary: what was run, the claims, the best and worst method of each
  scenario);
* ``report_decomposition.png``: the first scenario's section, its table, the notes on its
  large errors and its error-decomposition figure (unfolded) with its caption, cropped from
  the page;
* ``report_modes.png``: the top of the "Modes" section (each fit's modes against the
  finite-element modes: what is compared, the count found and the first scenarios' MAC
  figure), as a 256-colour palette image (a third of the size of full colour);
* ``figure_truss_forced_load38.png``: the study's figure file of the truss under load 38.

Each picture is cropped from a screenshot of the page itself (the element's position is
read from the page, in the same browser); the script refuses a blank picture (fewer than
5 % dark pixels). Needs Chromium (``chromium``, ``chromium-browser`` or ``google-chrome``)
and Pillow (a dependency of matplotlib).
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image

WIDTH = 1280
SHOTS = (  # file, CSS selector of the element (down to the bottom of a second one),
    # padding (px), max height (px)
    ("report.png", "body", None, 0, 1500),
    ("report_decomposition.png", "details.scenario", "details.scenario figure.decomposition",
     8, 2600),
    ("report_modes.png", "section#modes", None, 8, 870),
)
PALETTE = {"report_modes.png"}
"""Pictures written as 256-colour palette images (smaller files; plots and text only)."""
OPEN = "details.scenario, details.sub:has(figure.decomposition)"
"""The folded parts unfolded for the pictures: the scenario sections and the first
scenario's decomposition figure (the first match of each selector is what is shot)."""
_UNFOLD = ("<script>document.querySelectorAll(%r).forEach(function (d) { d.open = true; });"
           "</script>" % OPEN)


def _chromium() -> str:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        if path := shutil.which(name):
            return path
    sys.exit("report_images: Chromium not found (apt-get install chromium)")


def _browser(exe: str, work: Path, *args: str) -> subprocess.CompletedProcess:
    base = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
            "--no-first-run", "--disable-background-networking", "--disable-sync",
            f"--user-data-dir={work / 'profile'}", "--virtual-time-budget=5000"]
    return subprocess.run([*base, *args], capture_output=True, text=True, timeout=300,
                          check=True)


_PROBE = """<script>window.addEventListener("load", function () {
  var el = document.querySelector(%r);
  if (!el) { document.body.setAttribute("data-rect", "none"); return; }
  var r = el.getBoundingClientRect();
  document.body.setAttribute("data-rect", [r.left + scrollX, r.top + scrollY, r.width,
    r.height].map(Math.round).join(","));
});</script>"""


def _rect(exe: str, work: Path, page: str, selector: str) -> tuple[int, int, int, int]:
    probe = work / "probe.html"
    probe.write_text(page.replace("</body>", _UNFOLD + (_PROBE % selector) + "</body>"),
                     encoding="utf-8")
    dom = _browser(exe, work, f"--window-size={WIDTH},1000", "--dump-dom",
                   probe.as_uri()).stdout
    m = re.search(r'data-rect="(-?\d+),(-?\d+),(\d+),(\d+)"', dom)
    if m is None:
        sys.exit(f"report_images: no element {selector!r} in the page")
    left, top, width, height = map(int, m.groups())
    return left, top, width, height


def shoot(exe: str, work: Path, page: str, selector: str, until: str | None, pad: int,
          max_h: int) -> Image.Image:
    """The element ``selector`` of ``page`` (down to the bottom of ``until``) as the browser
    paints it, at most ``max_h`` px tall: the page is shifted up so the element starts at the
    top of the window."""
    left, top, width, height = _rect(exe, work, page, selector)
    if until is not None:
        _, top2, _, height2 = _rect(exe, work, page, until)
        height = top2 + height2 - top
    y0 = max(0, top - pad)
    h = min(height + 2 * pad, max_h)
    shifted = work / "shot.html"
    shifted.write_text(page.replace(
        "</head>", f"<style>body {{ position: relative; top: -{y0}px; }} "
        "nav.toc { position: static; }</style></head>").replace(
        "</body>", _UNFOLD + "</body>"), encoding="utf-8")
    png = work / "shot.png"
    _browser(exe, work, f"--window-size={WIDTH},{h}", f"--screenshot={png}", shifted.as_uri())
    img = Image.open(png).convert("RGB")
    if selector != "body":
        img = img.crop((max(0, left - pad), 0, min(WIDTH, left + width + pad), h))
    gray = np.asarray(img.convert("L"), dtype=float) / 255
    if (gray < 0.5).mean() < 0.05 * (0.2 if selector != "body" else 1) or gray.std() < 0.05:
        sys.exit(f"report_images: the picture of {selector!r} is blank")
    return img


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--report", type=Path, help="an existing report.html (default: run "
                    "podbench run chapter4 into a temporary folder)")
    ap.add_argument("--out", type=Path, default=Path("docs/img"))
    a = ap.parse_args(argv)
    exe = _chromium()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        report = a.report
        if report is None:  # as a user runs it, in an empty folder (a cold cache)
            subprocess.run([sys.executable, "-m", "podbench", "run", "chapter4", "-q"],
                           check=True, cwd=work)
            report = work / "results" / "chapter4" / "report.html"
        page = report.read_text(encoding="utf-8")
        a.out.mkdir(parents=True, exist_ok=True)
        for name, selector, until, pad, max_h in SHOTS:
            img = shoot(exe, work, page, selector, until, pad, max_h)
            if name in PALETTE:
                img = img.quantize(256)
            img.save(a.out / name, optimize=True)
            print(a.out / name)
        fig = report.parent / "figures" / "truss_forced__satellite_truss__load38.png"
        if fig.exists():
            shutil.copyfile(fig, a.out / "figure_truss_forced_load38.png")
            print(a.out / "figure_truss_forced_load38.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
