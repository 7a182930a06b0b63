"""The estimator contract every POD-based method must honour (inherited by each method's tests).

A subclass sets ``method`` (the class) and implements ``case()`` returning a SimpleNamespace:

* ``params``: constructor keywords giving ``k < m`` modes (so the projection error is not 0);
* ``fit(model, basis=None)``: fits ``model`` on the training data and returns what fit returns;
* ``predict_train(model)``: a list of ``(prediction, W)`` pairs, the model's prediction of
  each training excitation and the training response it must reproduce;
* ``predict_new(model)``: a prediction for a new excitation;
* ``bad_param``: ``(name, value)`` that fit must reject;
* ``records``: the training data as :class:`podbench.Record` objects (the record form of
  ``fit``), and ``target``: a record of the new excitation (the record form of ``predict``).
"""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from sklearn.base import clone

from podbench import Record
from podbench.errors import DimensionError, InputError, NotFittedError
from podbench.sysid.methods import PODMethod
from podbench.sysid.pod import projection_error


class MethodContract:
    method: type

    def case(self):  # pragma: no cover - overridden
        raise NotImplementedError

    def fitted(self):
        c = self.case()
        model = self.method(**c.params)
        return c, model, c.fit(model)

    def test_fit_returns_self(self):
        _, model, out = self.fitted()
        assert out is model

    def test_fitted_state_ends_in_underscore(self):
        c, model, _ = self.fitted()
        k = model.n_modes_
        m = model.modes_.shape[0]
        assert model.modes_.shape == (m, k)
        np.testing.assert_allclose(model.modes_.T @ model.modes_, np.eye(k), atol=1e-12)
        assert model.povs_.shape == (k,)
        assert model.pocs_.shape[1] == k
        fresh = self.method(**c.params)
        assert not [a for a in vars(fresh) if a.endswith("_")]

    def test_predict_shape(self):
        c, model, _ = self.fitted()
        W = c.predict_train(model)[0][1]
        assert c.predict_new(model).shape == W.shape

    def test_predict_before_fit_raises(self):
        c = self.case()
        with pytest.raises(NotFittedError, match="not fitted"):
            c.predict_new(self.method(**c.params))

    def test_unknown_keyword_is_type_error(self):
        with pytest.raises(TypeError):
            self.method(n_mode=3)

    def test_constructor_stores_and_fit_validates(self):
        c = self.case()
        name, value = c.bad_param
        model = self.method(**{**c.params, name: value})  # no validation here
        assert getattr(model, name) == value
        with pytest.raises(InputError, match=name):
            c.fit(model)

    def test_get_set_params(self):
        c = self.case()
        model = self.method(**c.params)
        params = model.get_params()
        for key, value in c.params.items():
            assert params[key] == value
        assert model.set_params(**params) is model
        with pytest.raises(TypeError, match="unknown parameter"):
            model.set_params(not_a_parameter=1)
        assert repr(model).startswith(self.method.__name__ + "(")

    def test_reproduces_training_to_projection_error(self):
        c, model, _ = self.fitted()
        U = model.modes_
        for W_pred, W in c.predict_train(model):
            err = np.linalg.norm(W_pred - W) / np.linalg.norm(W)
            proj = projection_error(W, U)
            assert proj > 1e-4  # k < m: the floor is not trivially zero
            # the prediction is the projection U Uᵀ W itself, not just as accurate
            np.testing.assert_allclose(W_pred, U @ (U.T @ W), atol=1e-9 * np.abs(W).max())
            assert err == pytest.approx(proj, rel=1e-6)

    def test_basis_argument(self):
        c, model, _ = self.fitted()
        same = c.fit(self.method(**c.params), basis=model.modes_)
        expected = c.predict_new(model)
        tol = 1e-9 * np.abs(expected).max()
        np.testing.assert_allclose(c.predict_new(same), expected, atol=tol)
        # an arbitrary orthonormal basis sets k
        k = model.n_modes_
        rng = np.random.default_rng(0)
        Q = np.linalg.qr(rng.standard_normal((model.modes_.shape[0], k)))[0]
        params = {key: v for key, v in c.params.items() if key != "n_modes"}
        other = c.fit(self.method(**params), basis=Q)
        assert other.n_modes_ == k
        np.testing.assert_array_equal(other.modes_, Q)

    # ----------------------------------------------------------- the record contract
    def test_sklearn_clone(self):
        c, model, _ = self.fitted()
        copy = clone(model)
        assert type(copy) is self.method and copy is not model
        assert copy.get_params(deep=False) == model.get_params(deep=False)
        assert not [a for a in vars(copy) if a.endswith("_")]  # unfitted
        # the clone fits to the same numbers
        np.testing.assert_array_equal(c.predict_new(c.fit(copy)), c.predict_new(model))

    def test_record_form_equals_array_form(self):
        c, model, _ = self.fitted()
        by_records = self.method(**c.params).fit(c.records)
        np.testing.assert_array_equal(by_records.modes_, model.modes_)
        np.testing.assert_array_equal(by_records.predict(c.target), c.predict_new(model))
        # a fitted model survives pickling (it travels to worker processes)
        again = pickle.loads(pickle.dumps(by_records))
        np.testing.assert_array_equal(again.predict(c.target), by_records.predict(c.target))

    def test_declarations(self):
        c = self.case()
        model = self.method(**c.params)
        assert isinstance(model, PODMethod)
        assert model.excitation_kind in ("free", "forced", "mixed")
        fields = model.required_fields()
        assert "W" in fields and set(fields) <= {"W", "F", "w0", "v0", "dt"}
        for name in fields:  # each declared field is needed: removing it is an error
            if name == "W":
                continue
            rec = c.records[0]
            stripped = [Record(**{f: getattr(r, f) for f in ("W", "F", "w0", "v0", "dt")
                                  if f != name}) for r in c.records]
            if name == "w0" and model.excitation_kind == "free":
                continue  # a free displacement record without w0 uses W[:, 0]
            with pytest.raises(InputError, match=rf"records\[0\]\.{name}"):
                self.method(**c.params).fit(stripped)
            assert rec is c.records[0]
        twin = model.coupled_twin()
        if model.coupled:
            assert type(twin) is self.method
            assert twin.get_params(deep=False) == model.get_params(deep=False)
        else:
            assert twin is not None and twin.coupled
            assert twin.excitation_kind == model.excitation_kind

    def test_number_of_training_records_is_checked(self):
        c = self.case()
        lo, hi = self.method.n_records
        if hi is not None:
            with pytest.raises(InputError, match="training record"):
                self.method(**c.params).fit(list(c.records) + [c.records[0]])
        if lo > 1:
            with pytest.raises(InputError, match="training record"):
                self.method(**c.params).fit(c.records[: lo - 1])

    def test_sampling_interval_must_agree(self):
        c = self.case()
        model = self.method(**c.params)
        if "dt" not in model.required_fields():
            return
        recs = list(c.records)
        if len(recs) > 1:
            r = recs[-1]
            recs[-1] = Record(W=r.W, F=r.F, w0=r.w0, v0=r.v0, dt=2 * r.dt)
            with pytest.raises(DimensionError, match=rf"records\[{len(recs) - 1}\]\.dt"):
                self.method(**c.params).fit(recs)
        model.fit(c.records)
        t = c.target
        with pytest.raises(DimensionError, match=r"record\.dt.*differs"):
            model.predict(Record(W=t.W, F=t.F, w0=t.w0, v0=t.v0, dt=3 * t.dt))

    def test_hyperparameters_are_validated_without_data(self):
        c = self.case()
        name, value = c.bad_param
        model = self.method(**{**c.params, name: value})
        with pytest.raises(InputError, match=name):
            model._validate_params()
        self.method(**c.params)._validate_params()  # the good ones pass
