"""The study's figures and report.html: the load in words, the y-axis fitted to the truth
with off-scale methods marked, total errors and events on the figure, every format; a
self-contained, well-formed report page; and (with Chromium) the page as a browser shows it.
"""

import base64
import html
import json
import re
import shutil
import subprocess
import textwrap
from html.parser import HTMLParser

import matplotlib

matplotlib.use("Agg")
import matplotlib.image as mpimg  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from conftest import CHAIN_FORCED, CHAIN_FREE  # noqa: E402

from podbench import cli
from podbench.harness.runner import run_unit
from podbench.harness.series import prediction_series, truth_series
from podbench.report.figures import (
    MARGIN,
    FigureTask,
    describe_case,
    draw_figure,
    make_figure,
)
from podbench.report.html import text_to_html
from podbench.study.scenarios import Case

pytestmark = pytest.mark.heavy  # seconds per test: not in the fast tier (README)

CLAIMS = '''
[[claims]]
id = "chain-mds-exact"
source = "podbench test"
quote = "MDS reproduces a new free response of an LTI system exactly when k = m"
scenario = "chain_free"
structure = "chain_coupled"
target = "x6"
checks = ["MDS.total_error < 0.001"]
criterion = "total error below 0.1 %"

[[claims]]
id = "chain-povr-impossible"
source = "podbench test"
quote = "a claim made to fail"
scenario = "chain_free"
structure = "chain_coupled"
target = "x6"
checks = ["POVR.total_error < 0"]
note = """
Fails by construction: *no* error is negative (`total_error` >= 0). Checks:
  * one bullet, continued
    on an indented line
  * a second bullet with |x| = 1 in it
"""

[[remarks]]
title = "A table in a remark"
text = """
Words before the table.

| open point | the text | main study |
|---|:---:|---:|
| fracture | "breaks off" | element `10` removed |
| second row | two | three |

- a list after it
- and its **second** item
"""
'''


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


@pytest.fixture
def study(write_scenario, tmp_path, monkeypatch):
    """The two chain scenarios and a claims file, in tmp_path/scenarios."""
    monkeypatch.chdir(tmp_path)
    write_scenario(CHAIN_FREE, "chain_free")
    write_scenario(CHAIN_FORCED, "chain_forced")
    (tmp_path / "scenarios" / "claims.toml").write_text(CLAIMS, encoding="utf-8")
    return tmp_path / "scenarios"


def _run(study, out, *extra):
    assert cli.main(["run", str(study), "--out", str(out), "-q", "--no-cache", *extra]) == 0
    return (out / "report.html").read_text(encoding="utf-8")


# ------------------------------------------------------------------------------ words
@pytest.mark.parametrize("case, dt, t_end, words", [
    (Case("load5", force=({"kind": "pulse", "location": 23.0, "amplitude": 500.0,
                           "duration": 5e-4},)), 1e-4, 0.0499,
     "500-lbf 0.5-ms rectangular pulse at 23 in"),
    (Case("w3", initial_displacement={"kind": "static_displacement",
                                      "loads": [[14.0, 2000.0], [18.0, -1300.0]],
                                      "reference": "lti_beam"}), 1e-4, 0.0499,
     "initial displacement from static loads: 2000 lbf at 14 in, −1300 lbf at 18 in"),
    (Case("v8", initial_velocity={"kind": "impulse_velocity", "duration": 0.05,
                                  "impulses": [["face74.d_bot", 1125.0]]}), 0.05, 9.95,
     "initial velocity from 0.05-s impulses: 1125 lbf at face74.d_bot"),
    (Case("f6", force=({"kind": "pulse", "location": 2, "amplitude": 2.0, "duration": 0.06,
                        "by": "dof", "shape": "half_sine"},)), 0.004, 0.476,
     "2-lbf 60-ms half-sine pulse at DOF 2"),
    (Case("late", force=({"kind": "pulse", "location": 3.0, "amplitude": -1.0,
                          "duration": 0.4, "start": 1.0, "shape": "triangle"},)), 0.05, 9.95,
     "−1-lbf 0.4-s triangular pulse at 3 in from t = 1 s"),
])
def test_the_excitation_is_described_in_words_and_units(case, dt, t_end, words):
    assert describe_case(case, dt=dt, t_end=t_end) == words


def test_several_excitations_are_joined():
    case = Case("new", initial_displacement={"kind": "static_displacement",
                                             "loads": [[20.0, 120.0]]},
                force=({"kind": "pulse", "location": 24.0, "amplitude": 300.0,
                        "duration": 1e-3, "shape": "half_sine"},))
    assert describe_case(case, dt=1e-4, t_end=0.0499) == (
        "initial displacement from static loads: 120 lbf at 20 in; "
        "300-lbf 1-ms half-sine pulse at 24 in")


# ------------------------------------------------------------------------------ figures
def _task(tmp_path, fmt="png", embed=False, events=((3.0, "element 10 breaks: its "
                                                     "stiffness is removed"),)):
    t = 0.05 * np.arange(200)
    truth = 2.0 + np.sin(t)
    series = {"t": t, "truth": truth,
              "A": 1.02 * truth, "A__pe": np.full(t.size, 2.0),
              "B": 5.0 * truth, "B__pe": np.full(t.size, 400.0)}
    return FigureTask(path=tmp_path / f"fig.{fmt}", title="Truss, free response: truss, "
                      "target w6", subtitle="Initial displacement from static loads: 1 lbf",
                      series=series, methods=(("A", 0.0213), ("B", 4.0), ("C", float("nan"))),
                      events=events, fmt=fmt, embed=embed)


def test_the_figure_is_fitted_to_the_truth_and_marks_what_leaves_it(tmp_path):
    task = _task(tmp_path)
    fig = make_figure(task)
    a1, a2 = fig.axes
    truth = task.series["truth"]
    bottom, top = a1.get_ylim()
    assert bottom == 0.0
    assert truth.max() < top < 1.2 * truth.max() < task.series["B"].max()
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert legend == ["truth (simulated)", "A: total error 2.13 %",
                      "B: total error 400 %, off scale (peak 5× the truth's)",
                      "C: total error failed"]
    markers = [ln for ln in a1.lines if ln.get_marker() == "^"]
    assert len(markers) == 1 and np.all(markers[0].get_ydata() == top)
    assert fig._suptitle.get_text() == task.title
    assert task.subtitle in [t.get_text() for t in fig.texts]
    assert a2.get_yscale() == "log"
    for ax in (a1, a2):  # the fracture at 3 s, on both panels
        assert any(len(ln.get_xdata()) == 2 and np.allclose(ln.get_xdata(), 3.0)
                   for ln in ax.lines)
    assert "element 10 breaks (t = 3 s)" in [t.get_text() for t in a2.texts]
    assert a2.get_xlabel() == "Time, s"


def test_a_band_is_shaded_only_where_it_stays_inside_the_truths_axis(tmp_path):
    """A 90 % band narrow over the first half and 50× the truth over the second: the axis
    stays fitted to the truth, the shading covers the first half only (its top never above
    the axis) and the legend says at which share of the samples the band was left out."""
    task = _task(tmp_path)
    n = task.series["t"].size
    task.series["A__band"] = np.where(np.arange(n) < n // 2, 0.1, 50.0 * 3.0)
    fig = make_figure(task)
    a1 = fig.axes[0]
    bottom, top = a1.get_ylim()
    truth = task.series["truth"]
    assert bottom == 0.0 and truth.max() < top < 1.2 * truth.max()
    shades = [c for c in a1.collections if len(c.get_paths())]
    assert len(shades) == 1
    verts = np.concatenate([p.vertices for p in shades[0].get_paths()])
    assert verts[:, 1].max() <= top
    assert verts[:, 0].max() < task.series["t"][n // 2]
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert legend[1] == "A: total error 2.13 %, 90 % band off scale at 50 % of the samples"


def test_the_wide_figure_shows_two_sensors_and_the_spectrum(tmp_path):
    """A cantilever-like record at 25 sensors (a 4 Hz sinusoid, amplitude growing to the
    tip): the sensor panels hold the tip and mid-span histories, method B (5× the truth)
    leaves their scale and is marked; the spectrum peaks at 4 Hz at the truth's amplitude."""
    dt, n = 0.01, 400
    t = dt * np.arange(n)
    x = np.arange(25.0)
    W = np.outer((x / 24) ** 2, 0.5 * np.sin(2 * np.pi * 4.0 * t))  # 4 Hz: 16 cycles
    s = {"t": t, "truth": np.linalg.norm(W, axis=0)}
    s.update(truth_series(W, dt, positions=x, labels=[f"x{int(v)}" for v in x]))
    for label, g in (("A", 1.02), ("B", 5.0)):
        s[label] = g * s["truth"]
        s[label + "__pe"] = np.full(n, 100 * abs(g - 1))
        s.update(prediction_series(label, g * W, dt, s["sensors"]))
    task = FigureTask(path=tmp_path / "wide.png", title="Beam", subtitle="lti_beam, target p",
                      series=s, methods=(("A", 0.02), ("B", 4.0)), events=(), fmt="png")
    fig = make_figure(task)
    try:
        assert len(fig.axes) == 5
        tip, mid, spec = fig.axes[2:]
        assert [t.get_text() for t in tip.texts] == ["tip: x24"]
        assert [t.get_text() for t in mid.texts] == ["mid-span: x12"]
        # the tip's truth (±0.5 in, to the sampling) and the margin
        peak, trough = np.max(W[24]), np.min(W[24])
        margin = MARGIN * (peak - trough)
        assert tip.get_ylim() == pytest.approx((trough - margin, peak + margin))
        assert peak == pytest.approx(0.5, rel=5e-3)
        assert {ln.get_marker() for ln in tip.lines} >= {"^", "v"}  # B leaves it both ways
        assert tip.get_ylabel() == "w, in" and fig.axes[0].get_ylabel().endswith(
            "(Eq. 4.1), in")
        f, amp = spec.lines[0].get_data()
        assert f[np.argmax(amp)] == pytest.approx(4.0)
        assert np.max(amp) == pytest.approx(np.linalg.norm(0.5 * (x / 24) ** 2), rel=5e-3)
        assert spec.get_yscale() == "log" and spec.get_xlabel() == "Frequency, Hz"
    finally:
        plt.close(fig)
    draw_figure(task)
    assert mpimg.imread(task.path).shape[1] == 1800  # 12 in at 150 dpi


@pytest.mark.parametrize("fmt, magic, uri", [
    ("png", b"\x89PNG", "data:image/png;base64,"),
    ("svg", b"<?xml", "data:image/svg+xml;base64,"),
    ("pdf", b"%PDF", "data:image/png;base64,"),
])
def test_every_format_is_drawn_headless_and_embeddable(tmp_path, fmt, magic, uri):
    task = _task(tmp_path, fmt, embed=True)
    out = draw_figure(task)
    assert task.path.read_bytes().startswith(magic)
    assert out.startswith(uri)
    data = base64.b64decode(out.split(",", 1)[1])
    assert data.startswith(magic if fmt == "svg" else b"\x89PNG")
    assert plt.get_fignums() == []  # the worker closed its figure
    if fmt == "png":
        img = mpimg.imread(task.path)
        assert img.shape[1] == 1200 and img.shape[0] >= 800  # 150 dpi, 8 in wide
        assert draw_figure(_task(tmp_path, fmt, embed=False)) is None


def test_the_unit_result_carries_the_structures_events(write_scenario):
    path = write_scenario(textwrap.dedent("""
        [scenario]
        name = "{name}"
        title = "Truss, short free response"
        structures = ["satellite_truss"]
        n_samples = 70
        dt = 0.05
        targets = ["w2"]
        [cases.w1]
        initial_displacement = {{ kind = "static_displacement", loads = [["face44.d_bot", 11.3]] }}
        [cases.w2]
        initial_displacement = {{ kind = "static_displacement", loads = [["face4.d_bot", -89.9]] }}
        [[methods]]
        label = "POVR"
        method = "POVR"
        n_modes = 2
        train = ["w1"]
        options = {{ excitation = "displacement" }}
        """), "truss_short")
    res = run_unit(path, "satellite_truss")
    assert [(t, d.split(":")[0]) for t, d in res.events] == [
        (3.0, "element 10 breaks off and disappears")]


# ------------------------------------------------------------------------------ report.html
_VOID = {"area", "base", "br", "col", "embed", "hr", "img", "input", "link", "meta",
         "source", "track", "wbr"}


class _Checker(HTMLParser):
    """Every non-void element closed, in order; collects img sources and links."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.stack, self.errors, self.imgs, self.refs, self.ids = [], [], [], [], []
        self.doctype = None

    def handle_decl(self, decl):
        self.doctype = decl

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if "id" in a:
            self.ids.append(a["id"])
        if tag == "img":
            self.imgs.append(a)
        for k in ("src", "href"):
            if k in a:
                self.refs.append(a[k])
        if tag not in _VOID:
            self.stack.append(tag)

    def handle_endtag(self, tag):
        if not self.stack or self.stack[-1] != tag:
            self.errors.append(f"</{tag}> closes <{self.stack[-1] if self.stack else None}>")
            return
        self.stack.pop()


def test_the_report_is_one_wellformed_self_contained_page(study, tmp_path):
    page = _run(study, tmp_path / "results" / "small")
    p = _Checker()
    p.feed(page)
    p.close()
    assert p.doctype == "DOCTYPE html" and not p.errors and p.stack == []
    assert len(p.ids) == len(set(p.ids))  # unique anchors
    assert '<html lang="en">' in page and '<meta charset="utf-8">' in page
    # nothing loaded from elsewhere: images are data: URIs, links are anchors in the page
    # two prediction figures, one error-decomposition figure per scenario, the
    # calibration plot and the modes' MAC figure
    assert len(p.imgs) == 6 and all(i["src"].startswith("data:image/png;base64,")
                                    for i in p.imgs)
    assert all(r.startswith(("data:", "#")) for r in p.refs)
    assert all("#" + r[1:] in {"#" + i for i in p.ids} for r in p.refs if r.startswith("#"))
    assert not re.search(r"@import|url\(|https?://", page)
    # the contents: tables with coloured errors, findings, fits, definitions, provenance
    for needle in ("chain_free: Coupled chain, free response", "chain_forced",
                   'class="e0"', "chain-mds-exact", "chain-povr-impossible",
                   'badge reproduced', 'badge not-reproduced', "<em>no</em>",
                   "2 claims: 1 reproduced, 1 not reproduced", 'id="fits"', "condition_number",
                   "subspace_error = ‖Ŵ − P W‖ / N", "<dt>commit</dt>", "<dt>NumPy</dt>",
                   "<dt>matplotlib</dt>", "Coupled chain, free response (k = m = 5)",
                   'id="calibration"', "Spearman(estimate, realized)",
                   # Markdown as HTML: the note's list, the remark's table, checks in percent
                   "<li>one bullet, continued on an indented line</li>",
                   "<li>a second bullet with |x| = 1 in it</li>",
                   '<table class="md">', "<code>10</code>", "<strong>second</strong>",
                   "MDS.total_error &lt; 0.1 %", 'class="decomposition"',
                   "do not add up to the total"):
        assert needle in page, needle
    assert page.count('<table class="md">') == 1 and "|---" not in page
    assert "Traceback" not in page


def test_the_report_embeds_vector_figures_and_tables_do_not_change(study, tmp_path):
    out = tmp_path / "results" / "small"
    page = _run(study, out, "--figure-format", "svg")
    # the calibration plot is a file in the chosen format and embedded as PNG
    assert sorted(f.suffix for f in (out / "figures").iterdir()) == [".svg"] * 6
    assert page.count('src="data:image/svg+xml;base64,') == 2
    table = (out / "summary.csv").read_bytes()
    page = _run(study, out, "--figure-format", "pdf")
    assert sorted(f.suffix for f in (out / "figures").iterdir()) == [".pdf"] * 6
    assert page.count('src="data:image/png;base64,') == 6
    assert (out / "summary.csv").read_bytes() == table
    page = _run(study, out, "--no-figures")
    assert "<img" not in page and "Figures not drawn" in page
    assert (out / "summary.csv").read_bytes() == table


def test_a_bad_figure_format_is_one_line_and_exit_2(study, capsys):
    assert cli.main(["run", str(study), "--figure-format", "gif"]) == 2
    err = capsys.readouterr().err
    assert "--figure-format" in err and err.count("\n") == 1


def test_text_to_html_keeps_lists_code_and_escapes():
    out = text_to_html("A ``P = U Uᵀ`` <b>.\n\n* one\n  continued\n* **two**")
    assert out == ("<p>A <code>P = U Uᵀ</code> &lt;b&gt;.</p>\n"
                   "<ul><li>one continued</li><li><strong>two</strong></li></ul>")


# ------------------------------------------------------------------------------ browser
def _chromium():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    return None


_PROBE = """<script>window.addEventListener("load", function () {
  var de = document.documentElement, all = document.querySelectorAll("details");
  var out = {folded_height: de.scrollHeight, details: all.length,
             unfolded_at_load: Array.prototype.filter.call(all, function (d) {
               return d.open; }).length};
  // a link into a folded section unfolds it: the first claim's link in the verdict table
  var link = document.querySelector("table.verdicts a[href^='#claim-']");
  if (link) {
    link.click();
    var target = document.getElementById(link.getAttribute("href").slice(1));
    out.link_unfolds = target.offsetParent !== null && target.getBoundingClientRect().height > 0;
  }
  all.forEach(function (d) { d.open = true; });
  out.unfolded_height = de.scrollHeight;
  out.page_overflow = Math.max(0, de.scrollWidth - de.clientWidth);
  // every in-page link resolves; the column heads link to the glossary
  var ids = {};
  document.querySelectorAll("[id]").forEach(function (e) { ids[e.id] = true; });
  var links = document.querySelectorAll("a[href^='#']");
  out.links = links.length;
  out.broken = Array.prototype.filter.call(links, function (a) {
    return !ids[a.getAttribute("href").slice(1)]; }).map(function (a) {
    return a.getAttribute("href"); });
  out.head_terms = document.querySelectorAll("th a.term[href^='#g-']").length;
  // a table either fits its frame or sits in a frame that says it scrolls (the fits table)
  out.cut = Array.prototype.filter.call(document.querySelectorAll(".scroll"), function (f) {
    return f.scrollWidth > f.clientWidth + 1 && !f.classList.contains("sticky1"); }).length;
  out.images = document.images.length;
  var stat = Array.prototype.filter.call(document.querySelectorAll("header .stat"),
    function (e) { return /figures/.test(e.textContent); })[0];
  out.header_figures = stat ? parseInt(stat.querySelector("b").textContent, 10) : -1;
  document.body.setAttribute("data-probe", JSON.stringify(out));
  var pre = document.createElement("pre");
  pre.id = "probe-text";
  pre.textContent = document.querySelector("main").innerText;
  document.body.appendChild(pre);
});</script>"""
"""Measures the page in the browser (folded, then every section unfolded, as a reader who
opens them all) and copies the text a reader sees into ``<pre id="probe-text">``."""

_RAW_TABLE_ROW = re.compile(r"^\s*\|.*\|\s*$|\|\s*:?-{3,}:?\s*\|")
"""A Markdown table row left as text: a line starting and ending with a pipe, or a delimiter
row (``|---|``, ``| --- |``, ``|:---:|``)."""


def _browser_base(exe, tmp_path):
    return [exe, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
            "--no-first-run", "--disable-background-networking", "--disable-component-update",
            "--disable-sync", f"--user-data-dir={tmp_path / 'chromium'}",
            "--virtual-time-budget=5000"]


def check_page_in_browser(exe, page_path, tmp_path, n_images, width=1400):
    """What a reader's browser shows of ``page_path`` at ``width`` px: every image decoded
    with a non-zero natural size, every table inside a frame that scrolls sideways and
    nothing wider than the window, folded and unfolded; no table cut by its frame but the
    fit diagnostics' (which says it scrolls); every in-page link resolving; the header's
    figure count the images drawn; no Markdown table row left as text; and a screenshot of
    the top that is not blank. Returns ``(text, probe)``: the page's text with every section
    unfolded and the measurements."""
    base = _browser_base(exe, tmp_path)
    url = page_path.resolve().as_uri()
    dom = subprocess.run([*base, f"--window-size={width},2000", "--dump-dom", url],
                         capture_output=True, text=True, timeout=300, check=True).stdout
    body = re.search(r"<body[^>]*>", dom)
    assert body, dom[:500]
    attrs = dict(re.findall(r'(data-[\w-]+)="([^"]*)"', body.group(0)))
    # the page's own script counted the images the browser decoded (naturalWidth > 0)
    assert attrs["data-images"] == str(n_images)
    assert attrs["data-images-loaded"] == str(n_images) and attrs["data-ok"] == "yes"
    assert int(attrs["data-tables"]) > 0 and attrs["data-tables-unframed"] == "0"
    assert attrs["data-page-overflow"] == "0"  # the page never scrolls sideways
    assert "Traceback" not in dom and "failed:" not in dom
    probe_page = tmp_path / "probe.html"
    probe_page.write_text(page_path.read_text(encoding="utf-8").replace(
        "</body>", _PROBE + "</body>"), encoding="utf-8")
    dom = subprocess.run([*base, f"--window-size={width},2000", "--dump-dom",
                          probe_page.as_uri()],
                         capture_output=True, text=True, timeout=300, check=True).stdout
    m = re.search(r'data-probe="([^"]*)"', dom)
    assert m, dom[-500:]
    probe = json.loads(html.unescape(m.group(1)))
    assert probe["broken"] == [] and probe["links"] > 0
    assert probe["images"] == n_images == probe["header_figures"]
    assert probe["cut"] == 0 and probe["page_overflow"] == 0
    assert probe["details"] > 0 and probe["unfolded_height"] > probe["folded_height"]
    assert probe.get("link_unfolds", True)
    m = re.search(r'<pre id="probe-text">(.*?)</pre>', dom, re.S)
    assert m, dom[-500:]
    text = html.unescape(m.group(1))
    raw = [ln for ln in text.splitlines() if _RAW_TABLE_ROW.search(ln)]
    assert raw == [], raw[:5]
    shot = tmp_path / "report.png"
    subprocess.run([*base, f"--screenshot={shot}", f"--window-size={width},2000", url],
                   capture_output=True, timeout=300, check=True)
    img = mpimg.imread(shot)[..., :3]
    assert img.shape[:2] == (2000, width)
    gray = img.mean(axis=2)
    assert gray.std() > 0.1  # not blank: the dark header, tables and figures
    assert (gray < 0.5).mean() > 0.05 and (gray > 0.9).mean() > 0.3
    return text, probe


@pytest.mark.browser
def test_the_report_in_a_headless_browser(study, tmp_path):
    exe = _chromium()
    if exe is None:
        pytest.skip("Chromium not installed (apt-get install chromium): the report is not "
                    "checked in a browser")
    out = tmp_path / "results" / "small"
    _run(study, out)
    n_figures = len(list((out / "figures").iterdir()))
    text, probe = check_page_in_browser(exe, out / "report.html", tmp_path, n_figures)
    # the remark's Markdown table is a table: its cells are tab-separated in the text
    assert "fracture\t\"breaks off\"\telement 10 removed" in text
    assert "Words before the table." in text and "| open point" not in text
    # both scenarios unfolded at load (a small study), the figures and claims folded; every
    # error column's head links to the glossary (10 columns, two tables)
    assert probe["unfolded_at_load"] == 2 and probe["head_terms"] >= 20


def test_the_report_names_the_command_that_made_it(study, tmp_path):
    """The command line given to `podbench run` (not the Python process's) is in the page."""
    out = tmp_path / "results" / "cmd"
    page = _run(study, out, "--no-figures")
    expected = f"podbench run {study} --out {out} -q --no-cache --no-figures"
    assert html.escape(expected, quote=False) in page


def test_fits_table_writes_roundoff_residuals_as_zero():
    """A relative residual below 1e-10 is round-off (its digits differ between CPUs' BLAS
    kernels: 3.26547e-16 against 3.24243e-16 measured for one fit; 1.2e-12 against 0 between
    two exact routes of the appendix TLS) and is written as 0;
    a real residual keeps its value; other columns are untouched."""
    from types import SimpleNamespace

    from podbench.harness.tables import ROUNDOFF_RESIDUAL, fits_table, table_csv

    unit = SimpleNamespace(fits=[
        {"scenario": "s", "structure": "b", "method": "ML", "n_modes": 4, "solver": "block",
         "fit_residual": 3.26547e-16, "solver_residual": 1.21273e-12, "solver_rcond": 1e-15},
        {"scenario": "s", "structure": "b", "method": "ML-tls", "n_modes": 4, "solver": "tls-dt",
         "fit_residual": 0.0123, "solver_residual": 2 * ROUNDOFF_RESIDUAL,
         "solver_rcond": 1e-15},
    ])
    df = fits_table([unit])
    assert df["fit_residual"].tolist() == [0.0, 0.0123]
    assert df["solver_residual"].tolist() == [0.0, 2e-10]
    assert df["solver_rcond"].tolist() == [1e-15, 1e-15]
    assert ",0," in table_csv(df).splitlines()[1]


def test_fits_table_writes_noise_floor_estimates_to_two_digits():
    """auto's noise floor is an estimate whose fourth digit differs between BLAS kernels on
    clean single-precision records (1.87089e-06 against 1.87098e-06 measured): two
    significant digits in fits.csv; NaN (solvers without the test) stays empty."""
    from types import SimpleNamespace

    from podbench.harness.tables import fits_table, table_csv

    unit = SimpleNamespace(fits=[
        {"scenario": "s", "structure": "b", "method": "ML-auto", "n_modes": 2, "solver": "auto",
         "solver_noise_floor": 1.87089e-06},
        {"scenario": "s", "structure": "b", "method": "ML-auto", "n_modes": 2, "solver": "auto",
         "solver_noise_floor": 1.87098e-06},
        {"scenario": "s", "structure": "b", "method": "ML-ls", "n_modes": 2, "solver": "ls",
         "solver_noise_floor": float("nan")},
    ])
    lines = table_csv(fits_table([unit])).splitlines()
    assert lines[1].endswith(",1.9e-06") and lines[2].endswith(",1.9e-06")
    assert lines[3].endswith(",")


def test_tables_write_a_negative_zero_as_zero_and_six_digits():
    import pandas as pd

    from podbench.harness.tables import table_csv

    df = pd.DataFrame({"a": [-0.0, 1.23456789, -1e-300 * 0], "n": [1, 2, 3], "s": ["x", "y", "z"]})
    assert table_csv(df) == "a,n,s\n0,1,x\n1.23457,2,y\n0,3,z\n"


def test_the_summary_writes_error_estimates_to_three_digits():
    """A prediction's error estimate moves in its sixth digit between BLAS kernels: the
    table states it to three significant digits."""
    from types import SimpleNamespace

    from podbench.harness.runner import COLUMNS
    from podbench.harness.tables import summary_table

    row = dict.fromkeys(COLUMNS, 0.0) | {"scenario": "s", "structure": "b", "method": "ML",
                                         "target": "t", "n_modes": 3, "status": "ok",
                                         "error_estimate": 0.0115516}
    df = summary_table([SimpleNamespace(rows=[row, row | {"error_estimate": 0.0115515}])])
    assert df["error_estimate"].tolist() == [0.0116, 0.0116]


@pytest.mark.slow
@pytest.mark.browser
def test_the_chapter4_report_in_a_headless_browser(tmp_path):
    """The real page (Chapter 4: its claims' notes and remarks carry Markdown lists and a
    table): every image shown, every table framed, no raw Markdown in its text."""
    exe = _chromium()
    if exe is None:
        pytest.skip("Chromium not installed (apt-get install chromium)")
    out = tmp_path / "chapter4"
    assert cli.main(["run", "chapter4", "--out", str(out), "-q"]) == 0
    n_images = len(list((out / "figures").glob("*.png")))
    text, probe = check_page_in_browser(exe, out / "report.html", tmp_path, n_images)
    # the remark's table of readings, and one decomposition figure per scenario (7)
    assert "truss fracture\t§4.2:" in text
    assert len(list((out / "figures").glob("*__decomposition.png"))) == 7
    # at 1400 px the page opens at a readable height (over 44,000 px unfolded before the
    # sections folded): the summary, the seven tables and what their large errors mean
    assert probe["folded_height"] < 15000 < probe["unfolded_height"]
    assert "SL on lti_beam" in text and "diagonal assumption" in text
