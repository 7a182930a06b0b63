"""The F-16 ground vibration test study (Noël & Schoukens 2017) and the periodic methods:
the BLA and ML over one period against independent computations, level interpolation,
bad input, the study file, and the issue's BLA table on the full records."""

from pathlib import Path

import numpy as np
import pytest
import scipy.signal

import podbench as pb
from podbench import api
from podbench.core.recordfiles import read_record
from podbench.core.records import Record
from podbench.core.resources import bundled_scenarios
from podbench.errors import InputError, ScenarioFileError
from podbench.harness.f16_gvt import errors, level_files, load_levels
from podbench.study.f16_gvt import load_f16_gvt
from podbench.sysid.methods import MultipleLoad
from podbench.sysid.methods.periodic import (
    BestLinearApproximation,
    LevelInterpolatedML,
    interpolation_weights,
)

STUDY = bundled_scenarios() / "f16_gvt" / "f16_gvt.toml"
DATA = bundled_scenarios() / "f16_gvt" / "data"
SHARED = next((p / "shared" / "data" / "f16_gvt" for p in Path(__file__).resolve().parents
               if (p / "shared" / "data" / "f16_gvt").is_dir()), None)
N = 8192


def _short(level: int, periods: int = 3) -> Record:
    """A bundled level record cut to its first ``periods`` periods."""
    rec = read_record(level_files(DATA)[level])
    n = periods * N
    return Record(u=rec.u[:, :n], y=rec.y[:, :n], dt=rec.dt, input_units="N",
                  output_units="m/s^2", input_channels=rec.input_channels,
                    output_channels=rec.output_channels, name=rec.name)


def _pooled_by_hand(recs, lines):
    """The issue's pooled BLA, G = Σ Ȳ conj(Ū) / Σ |Ū|², written out with numpy."""
    num, den = 0, 0
    for r in recs:
        P = r.n_samples // N
        U = np.fft.rfft(r.u[0].reshape(P, N)[1:], axis=1).mean(0)
        Y = np.fft.rfft(r.y.reshape(3, P, N)[:, 1:], axis=2).mean(1)
        num = num + Y[:, lines] * np.conj(U[lines])
        den = den + np.abs(U[lines]) ** 2
    return num / den


def test_bla_and_ml_over_one_period_are_the_pooled_frequency_response():
    recs = [_short(1), _short(3)]
    bla = BestLinearApproximation(period=N).fit(recs)
    ml = MultipleLoad(inputs="periodic", period=N).fit(recs)
    # the 267 excited lines of the benchmark's multisine, 2-15 Hz
    assert bla.lines_.size == 267 and bla.lines_[0] == 41 and bla.lines_[-1] == 307
    assert np.allclose(bla.frequencies_[[0, -1]], [2.001953125, 14.990234375])
    G = _pooled_by_hand(recs, bla.lines_)
    assert np.max(np.abs(bla.frequency_response()[:, 0] - G)) < 1e-12 * np.max(np.abs(G))
    # k = n_out: ML is the BLA (U a rotation of the outputs), its prediction too
    assert np.max(np.abs(ml.frequency_response()[:, 0] - G)) < 1e-10 * np.max(np.abs(G))
    target = _short(2)
    a, b = bla.predict(target), ml.predict(target)
    assert np.max(np.abs(a - b)) < 1e-10 * np.max(np.abs(a))
    # the whole-record prediction is the linear convolution with the kernel over one period
    h = bla.kernel_[:, 0] * bla.dt_
    direct = np.array([np.convolve(target.u[0], hk)[: target.n_samples] for hk in h])
    assert np.max(np.abs(direct - a)) < 1e-10 * np.max(np.abs(a))


def _multisine(rng, lines, P, scale=1.0):
    """A multisine on ``lines`` of an N-sample period with random phases, P periods."""
    X = np.zeros(N // 2 + 1, dtype=complex)
    X[lines] = scale * np.exp(2j * np.pi * rng.random(lines.size))
    return np.tile(np.fft.irfft(X, n=N), P)[None, :]


def _system(u, b, a):
    """Outputs of three known IIR filters (a lightly damped structure's stand-in)."""
    return np.vstack([scipy.signal.lfilter(b[i], a, u[0]) for i in range(3)])


def test_bla_recovers_a_known_linear_system_and_predicts_a_new_multisine():
    rng = np.random.default_rng(0)
    lines = np.arange(20, 200)
    r, w = 0.995, 2 * np.pi * 0.01
    a = np.array([1.0, -2 * r * np.cos(w), r ** 2])  # poles at 0.995 e^(±jw): decays in <1 period
    b = [np.array([0.3, 0.1, 0.0]), np.array([0.0, 0.5, -0.2]), np.array([1.0, 0.0, 0.4])]
    recs = []
    for level in (1.0, 2.0):
        u = _multisine(rng, lines, 4, level)
        recs.append(Record(u=u, y=_system(u, b, a), dt=0.01, input_units="N",
                             output_units="m/s^2", name=f"level{level}"))
    bla = BestLinearApproximation(period=N).fit(recs)
    z = np.exp(2j * np.pi * lines / N)
    G = np.array([np.polyval(bi[::-1], 1 / z) / np.polyval(a[::-1], 1 / z) for bi in b])
    assert np.array_equal(bla.lines_, lines)
    assert np.max(np.abs(bla.frequency_response()[:, 0] - G)) < 1e-8 * np.max(np.abs(G))
    u = _multisine(rng, lines, 3, 1.5)
    y = _system(u, b, a)
    new = Record(u=u, y=y, dt=0.01, input_units="N", output_units="m/s^2", name="new")
    yh = bla.predict(new)
    ss = slice(N, None)  # the steady state: periods 2-3
    assert np.max(np.abs(yh[:, ss] - y[:, ss])) < 1e-7 * np.max(np.abs(y))
    assert np.max(np.abs(bla.predict_periodic(new) - y[:, -N:])) < 1e-7 * np.max(np.abs(y))


def test_the_noise_variance_matches_white_output_noise():
    rng = np.random.default_rng(1)
    lines = np.arange(10, 300)
    u = _multisine(rng, lines, 9)
    y = np.vstack([scipy.signal.lfilter([0.5, 0.2], [1.0, -0.5], u[0])] * 3)
    s = 0.01 * np.std(y)
    rec = Record(u=u, y=y + s * rng.standard_normal(y.shape), dt=0.01, input_units="N",
                   output_units="m/s^2", name="noisy")
    bla = BestLinearApproximation(period=N).fit([rec])
    # the DFT of white noise of variance s² has variance N s² per line; averaged over the
    # P = 8 steady-state periods and divided by |Ū|²
    U = np.fft.rfft(u[0, N: 2 * N])[lines]
    expected = N * s ** 2 / (8 * np.abs(U) ** 2)
    ratio = np.mean(bla.noise_variance_, axis=1) / np.mean(expected)
    assert np.all(np.abs(ratio - 1) < 0.15)


def test_interpolation_weights():
    assert np.allclose(interpolation_weights([10.0, 30.0], 15.0), [0.75, 0.25])
    assert np.allclose(interpolation_weights([10.0, 30.0, 50.0], 40.0), [0, 0.5, 0.5])
    assert np.allclose(interpolation_weights([10.0, 30.0], 40.0), [0, 1])  # clamp
    assert np.allclose(interpolation_weights([10.0, 30.0], 40.0, extrapolate="linear"),
                       [-0.5, 1.5])
    t = np.log(20 / 10) / np.log(40 / 10)
    assert np.allclose(interpolation_weights([10.0, 40.0], 20.0, scale="log"), [1 - t, t])
    assert np.allclose(interpolation_weights([10.0], 99.0), [1.0])


def test_level_interpolation_of_two_known_systems():
    rng = np.random.default_rng(2)
    lines = np.arange(20, 200)
    a = np.array([1.0, -1.2, 0.5])
    recs = []
    for level, gain in ((1.0, 1.0), (3.0, 2.0)):  # the "structure" changes with the level
        u = _multisine(rng, lines, 3, level)
        recs.append(Record(u=u, y=gain * _system(u, [[1.0, 0.2]] * 3, a), dt=0.01,
                             input_units="N", output_units="m/s^2", name=f"l{level}"))
    model = LevelInterpolatedML(period=N).fit(recs)
    u = _multisine(rng, lines, 3, 2.0)
    target = Record(u=u, y=None, dt=0.01, input_units="N", output_units="m/s^2",
                      name="target")
    levels = model.levels_
    w = (np.sqrt(np.mean(u[:, N:] ** 2)) - levels[0]) / (levels[1] - levels[0])
    # its prediction is the weighted one of the two levels' models (gain 1 + w)
    expected = (1 + w) * _system(u, [[1.0, 0.2]] * 3, a)
    assert 0.3 < w < 0.7
    yh = model.predict_periodic(target)
    assert np.max(np.abs(yh - expected[:, -N:])) < 1e-8 * np.max(np.abs(expected))


def test_the_bundled_records_are_the_shared_files():
    readme = (DATA / "README.md").read_text(encoding="utf-8")
    assert "J.P. Noël and M. Schoukens" in readme and "In podbench" in readme
    assert sorted(level_files(DATA)) == [1, 2, 3, 4, 5, 7]
    if SHARED is None:
        pytest.skip("the shared data folder is not beside this checkout")
    for f in SHARED.glob("*.npz"):
        assert (DATA / f.name).read_bytes() == f.read_bytes()


def test_errors_are_relative_and_in_m_per_s2():
    rec = _short(2)
    yh = rec.y * 0.9
    plan = load_f16_gvt(STUDY)
    e = errors(yh, rec, plan)
    assert abs(e["rel_ss"] - 0.1) < 1e-12 and abs(e["rel_whole"] - 0.1) < 1e-12
    ss = rec.y[:, N:]
    assert abs(e["erms_ss"] - 0.1 * np.sqrt(np.mean(ss ** 2))) < 1e-12
    assert abs(e["erms_ss_acc_wing"] - 0.1 * np.sqrt(np.mean(ss[1] ** 2))) < 1e-12


# ------------------------------------------------------------------------- bad input
def _copy_levels(tmp_path, levels=(1, 2, 3), periods=3, **change):
    """The study file and shortened level files in tmp_path; ``change``: level → a dict of
    replaced variables."""
    data = tmp_path / "data"
    data.mkdir()
    for n in levels:
        src = level_files(DATA)[n]
        with np.load(src, allow_pickle=False) as z:
            v = {k: z[k] for k in z.files}
        for k in ("inputs", "outputs", "voltage"):
            v[k] = v[k][:, : periods * N]
        v.update(change.get(f"level{n}", {}))
        np.savez(data / src.name, **v)
    text = STUDY.read_text(encoding="utf-8")
    (tmp_path / "f16_gvt.toml").write_text(text, encoding="utf-8")
    return load_f16_gvt(tmp_path / "f16_gvt.toml")


@pytest.mark.parametrize("change, message", [
    ({"dt": np.float64(0.005)}, "field `dt`: 0.005 s differs from"),
    ({"period_samples": np.int64(4096)},
     "field `period_samples`: 4096 differs from the study's period of 8192 samples"),
    ({"output_channels": np.array(["acc_excitation", "acc_wing", "acc_tail"])},
     "field `output_channels`: channel(s) acc_payload absent"),
])
def test_a_bad_level_file_is_one_line_naming_file_and_field(tmp_path, change, message):
    plan = _copy_levels(tmp_path, level3=change)
    with pytest.raises(InputError) as err:
        load_levels(plan)
    text = str(err.value)
    assert "f16_fullmsine_level3_37N.npz" in text and message in text and "\n" not in text


def test_a_record_shorter_than_two_periods_is_refused(tmp_path):
    plan = _copy_levels(tmp_path, levels=(1, 3), periods=1)
    with pytest.raises(InputError, match=r"level1_12N.npz: field `inputs`: 8192 samples, "
                                         r"fewer than 2 periods of 8192"):
        load_levels(plan)


def test_the_voltage_is_ignored_unless_asked(tmp_path):
    plan = _copy_levels(tmp_path, levels=(1, 3), level1={"voltage": np.zeros((1, 3 * N))})
    recs = load_levels(plan)
    assert recs[1].input_channels == ("force",) and np.any(recs[1].u)
    from dataclasses import replace
    recs = load_levels(replace(plan, input="voltage"))
    assert recs[1].input_units == "V" and not np.any(recs[1].u)


@pytest.mark.parametrize("old, new, message", [
    ('method = "ERA-measured"', 'method = "ERB-measured"',
     "field `f16_gvt.methods[8].method`: unknown method \"ERB-measured\"; did you mean"),
    ('options = { n_modes = 2 }', 'options = { n_mode = 2 }',
     "field `f16_gvt.methods[2].options`:"),
    ('{ train = [3], targets = [2] }', '{ train = [3], targets = [3] }',
     "field `f16_gvt.sets[0].targets`: level 3 is also a training level"),
    ('period = 8192', 'period = 1', "field `f16_gvt.period`: expected an integer >= 2"),
    ('input = "force"', 'input = "current"', "field `f16_gvt.input`: expected one of"),
    ('data = "data"', 'data = "nope"',
     'field `f16_gvt.data`: no such folder "nope" (relative to this file)'),
])
def test_a_bad_study_file_names_the_field(tmp_path, old, new, message):
    text = STUDY.read_text(encoding="utf-8")
    assert old in text
    path = tmp_path / "f16_gvt.toml"
    path.write_text(text.replace(old, new, 1), encoding="utf-8")
    (tmp_path / "data").symlink_to(DATA)
    with pytest.raises(ScenarioFileError) as err:
        load_f16_gvt(path)
    assert message in str(err.value) and "f16_gvt.toml" in str(err.value)


# ------------------------------------------------------------------- the whole study
@pytest.mark.heavy
def test_the_study_runs_on_shortened_records(tmp_path):
    """The runner, end to end, on three shortened levels and the cheap methods: tables,
    FINDINGS with the citation, the set whose level is missing reported as skipped."""
    _copy_levels(tmp_path, levels=(1, 2, 3, 4, 5))
    path = tmp_path / "f16_gvt.toml"
    text = path.read_text(encoding="utf-8")
    keep = ("BLA", "ML", "ML-interp", "FIR-LS")
    blocks = text.split("[[f16_gvt.methods]]")
    blocks = [blocks[0]] + [b for b in blocks[1:]
                            if any(f'label = "{k}"\n' in b for k in keep)]
    text = "[[f16_gvt.methods]]".join(blocks)
    text = text.replace('methods = ["BLA", "ML", "FIR-LS"]', 'methods = ["BLA", "ML"]')
    text = text.replace('requires = ["mdof"]', "requires = []")  # the kept methods need none
    path.write_text(text.replace("bands = true", "bands = false"), encoding="utf-8")
    res = pb.run(str(path), out=tmp_path / "out", figures=False, quiet=True)
    out = tmp_path / "out"
    for name in ("summary.csv", "bla.csv", "decomposition.csv", "levels.csv", "fits.csv",
                 "skipped.csv", "modes.csv", "poles.csv", "FINDINGS.md"):
        assert (out / name).is_file()
    findings = (out / "FINDINGS.md").read_text(encoding="utf-8")
    assert "Noël and M. Schoukens" in findings
    assert "levels 3, 5, 7 → 6: no file for levels 7, 6 in the data folder" in findings
    s = res.summary
    bla = s[(s.method == "BLA") & (s.train == "1+3") & (s.target == 2)].iloc[0]
    ml = s[(s.method == "ML") & (s.train == "1+3") & (s.target == 2)].iloc[0]
    assert abs(bla.rel_ss - ml.rel_ss) < 1e-4 and 0.2 < bla.rel_ss < 0.6
    skipped = (out / "skipped.csv").read_text()
    assert "7,6,7 6" in skipped


@pytest.mark.heavy
def test_the_issue_bla_table_on_the_full_records():
    """Every BLA number of the issue, to its three digits (periods 2-9 of the full
    records), the own-level floors and the interpolation between levels 1 and 3."""
    plan = load_f16_gvt(STUDY)
    levels = load_levels(plan)
    table = {((3,), 2): 0.385, ((1, 3), 2): 0.344, ((1, 3, 5), 2): 0.563, ((5,), 4): 0.228,
             ((3, 5), 4): 0.191, ((1, 3, 5), 4): 0.193, ((1,), 2): 0.495, ((1,), 4): 1.255,
             ((3,), 4): 0.661, ((2,), 2): 0.013, ((4,), 4): 0.178}

    def periodic_error(model, n):
        y = levels[n].y[:, N:].reshape(3, 8, N).transpose(1, 0, 2)
        return np.linalg.norm(y - model.predict_periodic(levels[n])[None]) / np.linalg.norm(y)

    for (train, n), value in table.items():
        model = BestLinearApproximation(period=N).fit([levels[t] for t in train])
        assert round(periodic_error(model, n), 3) == value, (train, n)
    interp = LevelInterpolatedML(period=N).fit([levels[1], levels[3]])
    assert round(periodic_error(interp, 2), 3) == 0.223


def test_a_missing_extra_refuses_the_run_before_any_work(monkeypatch):
    """The committed tables hold mdof's rows: without mdof the study refuses to run (and
    overwrite them with refusals), naming the entry and the extra."""
    import importlib.util

    from podbench.harness import f16_gvt as harness

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "mdof" else real(name, *a))
    monkeypatch.setattr(harness, "load_levels", lambda plan: pytest.fail("data were read"))
    with pytest.raises(InputError, match=r"f16_gvt.toml: field `f16_gvt.methods\[11\]` "
                                         r"\(mdof-SRIM\): needs the mdof package \(pip install "
                                         r"'podbench\[mdof\]'\)"):
        harness.run_study(load_f16_gvt(STUDY))


def test_the_periodic_methods_keep_the_estimator_contract():
    from sklearn.base import clone

    from podbench.errors import NotFittedError

    recs = [_short(1), _short(3)]
    for est in (MultipleLoad(inputs="periodic", period=N), BestLinearApproximation(period=N),
                LevelInterpolatedML(period=N)):
        with pytest.raises(NotFittedError):
            est.predict(recs[0])
        twin = clone(est)
        assert twin.get_params() == est.get_params() and twin.fit(recs) is twin
    with pytest.raises(InputError, match="Parameter `period`: required"):
        MultipleLoad(inputs="periodic").fit(recs)
    u = _multisine(np.random.default_rng(3), np.arange(20, 200), 3)
    synthetic = Record(u=u, y=np.vstack([u[0]] * 3), dt=0.01, input_units="N",
                         output_units="m/s^2", name="synthetic")
    with pytest.raises(InputError, match="Parameter `lines`: line 5 carries no input power"):
        BestLinearApproximation(period=N, lines=(5, 41)).fit([synthetic])
    with pytest.raises(InputError, match="Parameter `scale`: expected one of 'linear', 'log'"):
        LevelInterpolatedML(period=N, scale="cubic").fit(recs)


def test_rational_poles_recover_two_modes_and_their_shapes():
    """The common-denominator fit of an exact two-mode response returns its poles (and
    shapes up to scale), independent of the data: s = −ζω ± jω√(1−ζ²)."""
    from podbench.core.modeshapes import frequency_damping
    from podbench.sysid.periodic import rational_poles

    f = np.linspace(2.0, 15.0, 267)
    s = 2j * np.pi * f
    modes = [(5.0, 0.01, np.array([1.0, 0.5, -0.2])), (9.0, 0.03, np.array([0.3, -1.0, 0.8]))]
    G = 0
    for fn, z, phi in modes:
        w = 2 * np.pi * fn
        G = G + phi[:, None] * (s ** 2 / (s ** 2 + 2 * z * w * s + w ** 2))[None, :]
    poles, residues, misfit = rational_poles(G, f, n_poles=4)
    fr, zr = frequency_damping(poles[poles.imag > 0])
    order = np.argsort(fr)
    assert np.allclose(fr[order], [5.0, 9.0], rtol=1e-8)
    assert np.allclose(zr[order], [0.01, 0.03], rtol=1e-6)
    assert misfit < 1e-8


# ------------------------------------------------ podbench predict / fit on the files
def test_predict_and_fit_take_the_period_from_the_files(tmp_path):
    """`podbench predict/fit --method ML-periodic | BLA | ML-interp` on the shipped files
    (shortened): the period is the files' `period_samples`, and the prediction is that of
    the method fitted in Python with the period given; `--method ML` on them is
    ML-periodic, and `--solver ls` keeps the truncated kernel."""
    _copy_levels(tmp_path, levels=(1, 2, 3))
    files = level_files(tmp_path / "data")
    train, target = [files[1], files[3]], files[2]
    direct = {"ML-periodic": MultipleLoad(inputs="periodic", period=N),
              "BLA": BestLinearApproximation(period=N), "ML-interp": LevelInterpolatedML(period=N)}
    for name, est in direct.items():
        res = api.predict(name, train, [target], tmp_path / f"pred-{name}")
        assert res.config["parameters"]["period"] == N
        with np.load(tmp_path / f"pred-{name}" / f"{target.stem}.npz") as z:
            got = z["y_hat"]
        want = est.fit([_short(1), _short(3)]).predict(_short(2))
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-9 * np.abs(want).max())
    # plain ML on files that carry a period is the kernel over one period (the study's ML
    # row); --solver ls keeps the truncated kernel on the measured inputs
    res = api.predict("ML", train, [target], tmp_path / "pred-ML")
    assert res.config["parameters"]["inputs"] == "periodic"
    with np.load(tmp_path / "pred-ML" / f"{target.stem}.npz") as z:
        np.testing.assert_allclose(z["y_hat"], direct["ML-periodic"].predict(_short(2)),
                                   rtol=0, atol=1e-9 * np.abs(want).max())
    res = api.predict("ML", train, [target], tmp_path / "pred-ML-ls", solver="ls")
    assert res.config["parameters"]["inputs"] == "measured"
    assert res.config["parameters"]["n_lags"] == "auto"
    model = pb.fit("BLA", train, tmp_path / "fit-bla")
    np.testing.assert_allclose(model.predict(_short(2)), direct["BLA"].predict(_short(2)),
                               rtol=0, atol=1e-9 * np.abs(want).max())


def test_a_periodic_method_without_a_period_is_one_line(tmp_path):
    _copy_levels(tmp_path, levels=(1, 2, 3), level3={"period_samples": np.int64(4096)})
    files = level_files(tmp_path / "data")
    with pytest.raises(InputError) as err:
        api.predict("ML-periodic", [files[1], files[3]], [files[2]], tmp_path / "p1")
    text = str(err.value)
    assert text.startswith(str(files[3])) and "field `period_samples`: 4096 differs" in text
    for n in (1, 3):  # files without the field
        with np.load(files[n], allow_pickle=False) as z:
            v = {k: z[k] for k in z.files if k != "period_samples"}
        np.savez(files[n], **v)
    with pytest.raises(InputError, match=r"^Parameter `method`: BLA identifies the kernel over "
                                         r"one period .* no training file carries "
                                         r"`period_samples`"):
        pb.fit("BLA", [files[1], files[3]], tmp_path / "f1")
    assert not (tmp_path / "f1").exists() and not (tmp_path / "p1").exists()


def test_the_torsion_pole_is_the_one_carrying_the_wing_response():
    """Of three poles in the torsion band, the sweep takes the lightly damped mode with the
    response, not a near-undamped computational pole of large peak height between the
    lines nor a broad overdamped residual term of large residue."""
    from podbench.core.modeshapes import ModeSet
    from podbench.harness.f16_gvt import _torsion_pole

    def pole(f_hz, zeta):
        w = 2 * np.pi * f_hz
        return complex(-zeta * w, w * np.sqrt(1 - zeta ** 2))

    f = np.arange(2.0, 15.0, 400 / 8192)  # the period's line spacing (Hz)
    poles = np.array([pole(7.30, 0.006), pole(7.4512, 1e-6), pole(7.5, 0.9)])
    shapes = np.array([[0.1, 0.1, 0.1], [1.0, 2e-4, 40.0], [0.1, 0.1, 0.1]], dtype=complex)
    modes = ModeSet(poles, shapes, ("a", "wing", "b"), "test")
    # the computational pole's peak |r|/|Re s| is the highest, the overdamped one's residue
    peak = np.abs(shapes[1]) / np.abs(poles.real)
    assert np.argmax(peak) == 1 and np.argmax(np.abs(shapes[1])) == 2
    assert _torsion_pole(modes, 1, 1 / 400, f) == 0
    assert _torsion_pole(modes.subset(np.array([False, False, False])), 1, 1 / 400, f) is None


@pytest.mark.heavy
def test_the_modes_of_a_periodic_fit_are_its_responses_rational_fit():
    """`podbench fit`'s modes of a periodic model (BLA, ML-periodic, ML-interp): the
    stable physical poles of its frequency response's rational fit. A known lightly damped
    mode (the discrete pole 0.995·e^(±j2π·0.01) at Δt = 0.01 s: s = ln(z)/Δt) comes back
    with its frequency and damping; ML-interp gives it at each training level."""
    from podbench.harness.fit import modes_table
    rng = np.random.default_rng(0)
    lines = np.arange(20, 200)  # 0.24-2.4 Hz
    r, w = 0.995, 2 * np.pi * 0.01
    a = np.array([1.0, -2 * r * np.cos(w), r ** 2])
    b = [np.array([0.3, 0.1, 0.0]), np.array([0.0, 0.5, -0.2]), np.array([1.0, 0.0, 0.4])]
    recs = []
    for level in (1.0, 2.0):
        u = _multisine(rng, lines, 4, level)
        recs.append(Record(u=u, y=_system(u, b, a), dt=0.01, input_units="N",
                           output_units="m/s^2", name=f"level{level}"))
    s = np.log(r * np.exp(1j * w)) / 0.01
    f_true, z_true = abs(s) / (2 * np.pi), -s.real / abs(s)
    for est in (BestLinearApproximation(period=N), LevelInterpolatedML(period=N)):
        table, summary = modes_table(est.fit(recs))
        near = table[np.abs(table.frequency_hz - f_true) < 0.01 * f_true]
        n_sets = 2 if isinstance(est, LevelInterpolatedML) else 1
        assert len(near) == n_sets, table
        np.testing.assert_allclose(near.frequency_hz, f_true, rtol=1e-4)
        np.testing.assert_allclose(near.damping_ratio, z_true, rtol=1e-2)
        assert summary["modes_count"] == len(table) and "24 poles" in summary["modes_rule"][0]
        assert summary["realization"] is None and "16-32" in summary["modes_poles_range"]
    assert list(table.input_rms.unique()) == sorted(table.input_rms.unique())
