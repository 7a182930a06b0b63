"""Model files: save, load, predict identically; what is refused, in one line."""

import json
import pickle

import numpy as np
import pytest

from podbench.core.records import Record
from podbench.errors import InputError
from podbench.sysid.methods import ERA, MDS, POVR, MixedResponse, MultipleLoad, SingleLoad
from podbench.sysid.methods.fir import FIRLeastSquares
from podbench.sysid.models import FORMAT_VERSION, load_model, read_header, save_model

from ._cases import forced_case, free_case, mixed_case


def _forced():
    c = forced_case("coupled")
    return [Record(W=W, F=F, dt=c.dt) for W, F in zip(c.W, c.F, strict=True)], \
        Record(W=c.W_new, F=c.F_new, dt=c.dt)


def _free():
    c = free_case("coupled", "displacement")
    return [Record(W=W, w0=x, dt=c.dt) for W, x in zip(c.W, c.x0, strict=True)], \
        Record(W=c.W_new, w0=c.x0_new, dt=c.dt)


def _mixed():
    c = mixed_case("coupled")
    return [Record(W=W, w0=a, v0=b, F=F, dt=c.dt)
            for W, a, b, F in zip(c.W, c.w0, c.v0, c.F, strict=True)], \
        Record(W=c.W_all, w0=c.w0_new, v0=c.v0_new, F=c.F_new, dt=c.dt)


def _io():
    c = forced_case("coupled")
    rng = np.random.default_rng(5)
    recs = [Record(u=F, y=W + 1e-4 * np.std(W) * rng.normal(size=W.shape), dt=c.dt,
                     input_units="lbf", output_units="in", name=f"r{j}.npz")
            for j, (W, F) in enumerate(zip(c.W, c.F, strict=True))]
    return recs, Record(u=c.F_new, y=c.W_new, dt=c.dt, input_units="lbf",
                          output_units="in", name="target.npz")


CASES = {
    "POVR": (lambda: POVR(n_modes=3), lambda: (_free()[0][:1], _free()[1])),
    "MDS": (MDS, _free),
    "SL": (lambda: SingleLoad(n_modes=3, solver="cgls"), lambda: (_forced()[0][:1],
                                                                  _forced()[1])),
    "ML": (lambda: MultipleLoad(solver="block"), _forced),
    "MR": (lambda: MixedResponse(n_modes=3), _mixed),
    "ERA": (lambda: ERA(n_modes=5, max_order=12), _forced),
    "FIR-LS": (lambda: FIRLeastSquares(lag_grid=(0.05, 0.1)), _io),
    "ML-IO": (lambda: MultipleLoad(inputs="measured", n_lags="auto", solver="ls",
                                   lag_grid=(0.05, 0.1), prior="tc"), _io),
}


@pytest.mark.heavy
@pytest.mark.parametrize("name", list(CASES))
def test_a_loaded_model_predicts_exactly_as_the_fitted_one(name, tmp_path):
    make, data = CASES[name]
    train, target = data()
    est = make().fit(train)
    path = save_model(est, tmp_path / "model.npz")
    back = load_model(path)
    assert type(back) is type(est) and back.get_params(deep=False).keys() == \
        est.get_params(deep=False).keys()
    a, b = est.predict(target), back.predict(target)
    assert np.max(np.abs(a - b)) <= 1e-12 * np.max(np.abs(a))
    summary = json.loads((tmp_path / "model.json").read_text())
    assert summary["format_version"] == FORMAT_VERSION and summary["method"] == est.abbreviation
    assert "realization" in summary  # the realization and modes, or the reason


@pytest.mark.heavy
def test_the_band_and_its_calibration_travel_with_the_model(tmp_path):
    train, target = _io()
    est = MultipleLoad(inputs="measured", n_lags="auto", solver="ls", lag_grid=(0.05, 0.1))
    est.fit(train[:4])
    est.calibrate_band(n_draws=2, seed=3)  # not the defaults: must be carried, not redone
    back = load_model(save_model(est, tmp_path / "m.npz"))
    p, q = est.predict(target, coverage=0.9), back.predict(target, coverage=0.9)
    assert p.error_estimate == q.error_estimate
    np.testing.assert_array_equal(p.lower, q.lower)
    np.testing.assert_array_equal(p.upper, q.upper)


def test_provenance_names_the_training_files_and_their_hashes(tmp_path):
    train, _ = _io()
    files = []
    for j in range(2):
        f = tmp_path / f"train{j}.npz"
        f.write_bytes(b"record %d" % j)
        files.append(f)
    est = FIRLeastSquares(n_lags=5).fit(train[:2])
    save_model(est, tmp_path / "model.npz", training_files=files)
    header, _ = read_header(tmp_path / "model.npz")
    prov = header["provenance"]
    assert [t["name"] for t in prov["training_files"]] == ["train0.npz", "train1.npz"]
    import hashlib

    assert prov["training_files"][1]["sha256"] == hashlib.sha256(b"record 1").hexdigest()
    assert prov["dt"] == train[0].dt and prov["output_units"] == "in"
    # the hashes are provenance: a changed training file does not stop loading
    files[0].write_bytes(b"changed")
    load_model(tmp_path / "model.npz")


@pytest.mark.heavy
def test_bad_model_files_are_refused_in_one_line(tmp_path):
    train, _ = _forced()
    good = save_model(MultipleLoad(solver="block").fit(train), tmp_path / "good.npz")
    text = tmp_path / "text.npz"
    text.write_text("not a model")
    plain = tmp_path / "plain.npz"
    np.savez(plain, W=np.ones(3))
    pickled = tmp_path / "pickled.npz"
    np.savez(pickled, __header__=np.array([{"a": 1}], dtype=object))
    raw = tmp_path / "raw.npz"
    raw.write_bytes(pickle.dumps({"format": "podbench-model"}))
    header, arrays = read_header(good)
    future = tmp_path / "future.npz"
    np.savez(future, __header__=np.array(json.dumps({**header, "format_version": 99})),
             **arrays)
    alien = tmp_path / "alien.npz"
    np.savez(alien, __header__=np.array(json.dumps({**header, "class": "os:system"})),
             **arrays)
    edited = tmp_path / "edited.npz"  # a parameter added by hand to the header
    params = {**header["parameters"], "n_mode": 3}
    np.savez(edited, __header__=np.array(json.dumps({**header, "parameters": params})),
             **arrays)
    gap = tmp_path / "gap.npz"  # an array the header refers to, left out
    key = next(k for k in arrays if k != "__parameters__")
    np.savez(gap, __header__=np.array(json.dumps(header)),
             **{k: a for k, a in arrays.items() if k != key})
    cases = [(text, "not a podbench model"), (plain, "no `__header__`"),
             (pickled, "pickled objects"), (raw, "a pickle"), (future, "format_version`: 99"),
             (alien, "not podbench's"), (tmp_path / "absent.npz", "no such file"),
             (edited, "field `parameters.n_mode`: not a parameter of MultipleLoad"),
             (gap, f"array '{key}': missing")]
    for path, words in cases:
        with pytest.raises(InputError, match=words) as info:
            load_model(path)
        assert "\n" not in str(info.value) and path.name in str(info.value)


def test_an_edited_header_or_a_truncated_array_is_refused_naming_file_and_field(tmp_path):
    """The fitted arrays predict whatever the header's parameters say, so a hand-edited
    ``solver`` or ``n_modes`` would be silently ignored: it is refused, as is an array cut
    short (the header records every array's shape and dtype)."""
    train, new = _forced()
    good = save_model(SingleLoad(n_modes=3, solver="block").fit(train[:1]), tmp_path / "m.npz")
    header, arrays = read_header(good)
    expected = load_model(good).predict(new)

    def variant(name, header=header, **members):
        path = tmp_path / name / "model.npz"
        path.parent.mkdir()
        np.savez(path, __header__=np.array(json.dumps(header)), **{**arrays, **members})
        return path

    def edited(**params):
        return {**header, "parameters": {**header["parameters"], **params}}

    modes_key = header["state"]["modes_"]["key"]
    cases = [
        (variant("n_modes", edited(n_modes=2)),
         "field `parameters.n_modes`: 2 in the header, but the arrays were fitted with 3"),
        (variant("solver", edited(solver="ls")),
         'field `parameters.solver`: "ls" in the header, but the arrays were fitted with "block"'),
        (variant("cut", **{modes_key: arrays[modes_key].ravel()[:7]}),
         f"array '{modes_key}': <f8 [7], but the header recorded <f8 "
         f"{list(arrays[modes_key].shape)} for `model.modes_`"),
    ]
    folder = good.parent / "fitted"
    folder.mkdir()
    good.rename(folder / "model.npz")
    cases.append((folder, f"a folder, not a model file; the model podbench fit wrote there "
                          f"is {folder / 'model.npz'}"))
    for path, words in cases:
        with pytest.raises(InputError) as info:
            load_model(path)
        message = str(info.value)
        assert message.startswith(f"{path}: ") and words in message and "\n" not in message
    # the unedited copy, and a file of before the fitted parameters were kept, still predict
    same = variant("same")
    older = tmp_path / "older.npz"
    np.savez(older, __header__=np.array(json.dumps(header)),
             **{k: a for k, a in arrays.items() if k != "__parameters__"})
    for path in (same, older):
        np.testing.assert_array_equal(load_model(path).predict(new), expected)


def test_saving_refuses_what_the_format_cannot_hold(tmp_path):
    train, _ = _forced()
    est = MultipleLoad(solver="block").fit(train)
    est.extra_ = object()
    with pytest.raises(InputError, match="attribute `model.extra_`"):
        save_model(est, tmp_path / "model.npz")
    with pytest.raises(InputError, match="not fitted"):
        save_model(MultipleLoad(), tmp_path / "model.npz")
    with pytest.raises(InputError, match=".npz"):
        save_model(est, tmp_path / "model.pkl")


def test_saving_does_not_realize_and_the_summary_says_what_was_computed(tmp_path):
    from podbench.sysid.models import NOT_REALIZED, Model
    from podbench.sysid.realize import to_statespace

    train, _ = _forced()
    est = MultipleLoad(solver="block").fit(train)
    model = Model(est)
    model.save(tmp_path / "plain.npz")
    plain = json.loads((tmp_path / "plain.json").read_text())
    assert plain["realization"] is None and plain["realization_note"] == NOT_REALIZED
    assert model._statespace is None  # saving made no realization
    # after modes(): the realization made for them is written, the same as a fresh one
    table = model.modes()
    model.save(tmp_path / "realized.npz")
    done = json.loads((tmp_path / "realized.json").read_text())
    fresh = to_statespace(est)
    assert done["realization"] == fresh.realization and done["order"] == fresh.order
    assert [m["frequency_hz"] for m in done["modes"]] == list(table["frequency_hz"])
    # save_model(realize=True) realizes for the summary
    save_model(est, tmp_path / "now.npz", realize=True)
    now = json.loads((tmp_path / "now.json").read_text())
    assert now["realization"] == fresh.realization and "realization_note" not in now
