"""The estimator contract every POD-based method must honour (inherited by each method's tests).

A subclass sets ``method`` (the class) and implements ``case()`` returning a SimpleNamespace:

* ``params``: constructor keywords giving ``k < m`` modes (so the projection error is not 0);
* ``fit(model, basis=None)``: fits ``model`` on the training data and returns what fit returns;
* ``predict_train(model)``: a list of ``(prediction, W)`` pairs, the model's prediction of
  each training excitation and the training response it must reproduce;
* ``predict_new(model)``: a prediction for a new excitation;
* ``bad_param``: ``(name, value)`` that fit must reject.
"""

from __future__ import annotations

import numpy as np
import pytest

from podbench.errors import InputError, NotFittedError
from podbench.pod import projection_error


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
