"""Modes of identified models: the state-space realizations of the fitted methods reproduce
their predictions and hold the finite-element modes, computed here independently (scipy's
eigensolver of the test systems' M, C, K and the trapezoidal map of the test integrator)."""

import numpy as np
import pytest
import scipy.linalg

from podbench.core.modeshapes import ModeSet, mac
from podbench.core.records import Record
from podbench.errors import InputError
from podbench.sysid.methods import ERA, MDS, POVR, MixedResponse, MultipleLoad, SingleLoad
from podbench.sysid.modal import (
    STABILITY,
    discrete_modes,
    match_modes,
    physical_mask,
    stability_mask,
)
from podbench.sysid.realize import to_statespace

from ._cases import forced_case, free_case, mixed_case
from ._truth import eigenmodes, newmark, rel_err


def _truth_modes(M, C, K, dt) -> ModeSet:
    """The modes a record of the test integrator (average-acceleration Newmark, the
    trapezoidal rule) holds: eig of the first-order form, z = (1 + sΔt/2)/(1 − sΔt/2),
    s' = ln z/Δt; shapes at every DOF (every DOF is a sensor)."""
    n = M.shape[0]
    Ac = np.block([[np.zeros((n, n)), np.eye(n)],
                   [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    lam, V = scipy.linalg.eig(Ac)
    up = lam.imag > 0
    z = (1 + lam[up] * dt / 2) / (1 - lam[up] * dt / 2)
    return ModeSet(np.log(z) / dt, V[:n, up], tuple(str(i) for i in range(n)))


def _records(case, forced=True):
    if forced:
        return [Record(W=W, F=F, dt=case.dt) for W, F in zip(case.W, case.F, strict=True)]
    return [Record(W=W, w0=x, dt=case.dt) for W, x in zip(case.W, case.x0, strict=True)]


def _assert_modes_exact(ss, case, tol=1e-8):
    truth = _truth_modes(case.M, case.C, case.K, case.dt)
    table = match_modes(ss.modes(), truth)
    assert table["identified"].notna().all(), table
    assert np.max(np.abs(table["frequency_error_pct"])) < 100 * tol
    assert np.max(np.abs(table["damping_error_rel"])) < tol * 100
    assert table["mac"].min() > 1 - tol


def test_discrete_modes_of_known_poles_and_the_hard_criteria():
    dt = 0.01
    s = np.array([-0.3 + 2j * np.pi * 4.0, -2.0 + 2j * np.pi * 11.0])
    phi = np.array([[1.0, 0.5, -0.2], [0.3, -1.0, 0.8]]).T
    blocks, cols = [], []
    for sk, ph in zip(s, phi.T, strict=True):
        z = np.exp(sk * dt)
        blocks.append(np.array([[z.real, -z.imag], [z.imag, z.real]]))
        cols.append(np.column_stack([ph, np.zeros(3)]))  # eigvec (1, ∓i)/√2 → shape ph/√2
    A = scipy.linalg.block_diag(*blocks)
    C = np.hstack(cols)
    modes = discrete_modes(A, C, dt)
    np.testing.assert_allclose(modes.poles, s, rtol=1e-12)
    np.testing.assert_allclose(np.diag(mac(modes.shapes, phi)), 1.0, atol=1e-12)
    np.testing.assert_allclose(modes.damping_ratio, -s.real / np.abs(s), rtol=1e-12)
    assert physical_mask(modes, dt).all()
    # a growing mode and a mode above Nyquist (|s| > π/Δt) fail the hard criteria
    bad = ModeSet(np.array([0.1 + 2j * np.pi * 4, -200.0 + 2j * np.pi * 45]),
                  np.ones((3, 2)), ("0", "1", "2"))
    assert not physical_mask(bad, dt).any()


def test_stability_rule_uses_the_stated_tolerances():
    base = ModeSet(np.array([-0.5 + 2j * np.pi * 10]), np.array([[1.0], [0.5]]), ("a", "b"))
    f, z = base.frequency_hz[0], base.damping_ratio[0]

    def moved(df, dz, shape=(1.0, 0.5)):
        w = 2 * np.pi * f * (1 + df)
        zeta = z * (1 + dz)
        return ModeSet(np.array([-zeta * w + 1j * w * np.sqrt(1 - zeta**2)]),
                       np.array([shape]).T, ("a", "b"))

    assert stability_mask(base, [moved(0.009, 0.04)]).all()
    assert not stability_mask(base, [moved(0.011, 0.0)]).any()
    assert not stability_mask(base, [moved(0.0, 0.06)]).any()
    assert not stability_mask(base, [moved(0.0, 0.0, (1.0, -0.5))]).any()  # MAC 0.36
    assert STABILITY == {"frequency": 0.01, "damping": 0.05, "mac": 0.97}


def test_matching_is_by_mac_not_by_index():
    rng = np.random.default_rng(3)
    Q = np.linalg.qr(rng.normal(size=(6, 4)))[0]
    poles = -0.1 + 2j * np.pi * np.array([3.0, 5.0, 8.0, 13.0])
    ref = ModeSet(poles, Q, tuple("abcdef"))
    # identified: modes 2 and 3 swapped in frequency order (a frequency shift), mode 4 lost
    ident = ModeSet(poles[[0, 2, 1]] * np.array([1.001, 1.0, 1.0]), Q[:, [0, 1, 2]] * 1j,
                    tuple("abcdef"))
    t = match_modes(ident, ref)
    assert t["identified"].tolist()[:3] == [1.0, 3.0, 2.0] and np.isnan(t["identified"][3])
    np.testing.assert_allclose(t["mac"][:3], 1.0, atol=1e-12)
    assert t["frequency_error_pct"][0] == pytest.approx(0.1, rel=1e-6)
    with pytest.raises(InputError, match="channels"):
        match_modes(ModeSet(poles, Q, tuple("uvwxyz")), ref)


def test_frequency_tie_break_pairs_shared_shapes_by_frequency():
    rng = np.random.default_rng(4)
    Q = np.linalg.qr(rng.normal(size=(6, 2)))[0]
    ref = ModeSet(-0.1 + 2j * np.pi * np.array([4.0, 11.0]), Q[:, [1, 0]], tuple("abcdef"))
    # a diagonal kernel's realization: poles at 3 and 11.2 Hz both with POM 1's shape (MAC 1
    # with the 11-Hz reference mode: a tie), one at 4.1 Hz with POM 2's
    shapes = Q[:, [0, 1, 0]]
    ident = ModeSet(-0.1 + 2j * np.pi * np.array([3.0, 4.1, 11.2]), shapes, tuple("abcdef"))
    by_mac = match_modes(ident, ref, rule="mac")
    tied = match_modes(ident, ref)  # the default rule breaks the tie by frequency
    assert by_mac["identified_frequency_hz"][1] == pytest.approx(3.0, rel=1e-3)  # MAC alone
    assert tied["identified"].tolist() == [2.0, 3.0]  # 4.1 Hz for 4 Hz, 11.2 Hz for 11 Hz
    np.testing.assert_allclose(tied["identified_frequency_hz"], [4.1, 11.2], rtol=1e-4)
    np.testing.assert_allclose(tied["mac"], by_mac["mac"], atol=1e-12)  # MAC unchanged
    # a MAC more than one step (MAC_TIE) higher still wins over a nearer frequency
    worse = shapes.copy()
    worse[:, 2] += 0.2 * Q[:, 1]  # the 11.2-Hz mode: MAC 0.96 with the reference
    t = match_modes(ModeSet(ident.poles, worse, tuple("abcdef")), ref)
    assert t["identified_frequency_hz"][1] == pytest.approx(3.0, rel=1e-3)
    with pytest.raises(InputError, match="`rule`"):
        match_modes(ident, ref, rule="frequency")


@pytest.mark.heavy
@pytest.mark.parametrize("method", [MultipleLoad(solver="block"), ERA(n_modes=5)])
def test_forced_realizations_reproduce_the_prediction_and_the_modes(method):
    case = forced_case("coupled")
    est = method.fit(_records(case))
    ss = to_statespace(est)
    assert ss.order == 10 and not ss.is_free
    target = Record(W=case.W_new, F=case.F_new, dt=case.dt)
    assert rel_err(ss.respond(case.F_new), est.predict(target)) < 1e-8
    _assert_modes_exact(ss, case)
    dl = ss.to_dlti()
    assert dl.dt == case.dt and dl.A.shape == (10, 10)


@pytest.mark.heavy
@pytest.mark.parametrize("method", [MDS(), ERA(n_modes=5, excitation="displacement")])
def test_free_realizations_are_autonomous_and_hold_the_modes(method):
    case = free_case("coupled", "displacement")
    est = method.fit(_records(case, forced=False))
    ss = to_statespace(est)
    assert ss.is_free and ss.B is None and ss.D is None
    assert rel_err(ss.respond_free(case.x0_new, case.n), est.predict(case.x0_new)) < 1e-8
    _assert_modes_exact(ss, case)
    with pytest.raises(InputError, match="no input"):
        ss.to_dlti()


@pytest.mark.heavy
def test_diagonal_methods_realize_their_diagonal():
    """SL, POVR and MR's forced part realize the diagonal they identified. In the ideal
    chain's normal modes (M = I, Rayleigh damping: the diagonal assumption holds exactly)
    every diagonal kernel or free decay is one mode, and the realization holds the truth's;
    in their own POMs they are approximations (POMs are not exactly the normal modes)."""
    ideal = forced_case("ideal")
    U = eigenmodes(ideal.M, ideal.K)
    sl = SingleLoad(solver="block").fit(Record(W=sum(ideal.W), F=sum(ideal.F), dt=ideal.dt),
                                        basis=U)
    ss = to_statespace(sl)
    assert "diagonal kernel" in ss.realization
    target = Record(W=ideal.W_new, F=ideal.F_new, dt=ideal.dt)
    assert rel_err(ss.respond(ideal.F_new), sl.predict(target)) < 1e-8
    _assert_modes_exact(ss, ideal)
    free = free_case("ideal", "displacement")
    povr = POVR().fit(Record(W=free.W[0], w0=free.x0[0], dt=free.dt), basis=U)
    ss = to_statespace(povr)
    assert rel_err(ss.respond_free(free.x0_new, free.n), povr.predict(free.x0_new)) < 1e-8
    _assert_modes_exact(ss, free)
    mixed = mixed_case("ideal")
    mr = MixedResponse(solver="block").fit(
        [Record(W=W, w0=a, v0=b, F=F, dt=mixed.dt)
         for W, a, b, F in zip(mixed.W, mixed.w0, mixed.v0, mixed.F, strict=True)], basis=U)
    _assert_modes_exact(to_statespace(mr), mixed)


@pytest.mark.heavy
def test_io_ml_realization_and_the_refusals():
    """ML on input/output records with a kernel over the whole record ('block', exact) is a
    model of order 2k; a truncated kernel would be approximated."""
    case = forced_case("coupled")
    u = np.zeros((1, case.n))
    u[0, 1:] = 100.0 * 0.6 ** np.arange(case.n - 1)  # minimum phase: a stable substitution
    F = np.zeros((5, case.n))
    F[2] = u[0]
    W = newmark(case.M, case.C, case.K, case.dt, case.n, F=F)[0]
    recs = [Record(u=u, y=W, dt=case.dt, input_units="lbf", output_units="in",
                     input_channels=("f",), name="r.npz")]
    ml = MultipleLoad(inputs="measured", n_lags=None, solver="block").fit(recs[:1])
    ss = to_statespace(ml)
    target = Record(u=case.F_new[[1]], y=None, dt=case.dt, input_units="lbf",
                      output_units="in", input_channels=("f",))
    assert rel_err(ss.respond(target.u), ml.predict(target)) < 1e-8
    assert ss.input_channels == ("f",) and ss.output_units == "in"
    _assert_modes_exact(ss, case)
    with pytest.raises(InputError, match="not fitted"):
        to_statespace(MultipleLoad())
    with pytest.raises(InputError, match="exceeds"):
        to_statespace(ml, order=10_000)
    with pytest.raises(InputError, match="no dt"):
        to_statespace(POVR(n_modes=2).fit(Record(W=free_case("ideal", "displacement").W[0])))


@pytest.mark.heavy
def test_beam_ml_realization_is_exact_and_holds_scipys_modes():
    """The aluminium beam (40 DOFs, 5 measured sensors, ζ = 0.5 %): ML from five pulses at
    the measured sensors is exact (k = 5), and its realization (order 80, the beam's state
    dimension) reproduces ML's prediction and holds the modes of scipy's eigensolution of the
    FE matrices, mapped by the trapezoidal rule of the Newmark records."""
    import podbench as pb

    beam = pb.load_structure("aluminium_beam")
    dt, n = 2e-4, 600
    shape = np.sin(np.pi * np.arange(1, 8) / 8)

    def pulse(j):
        F = np.zeros((6, n))
        F[j, 1:8] = shape
        return pb.simulate(beam, n, dt, force=F)

    ml = MultipleLoad(solver="block").fit([pulse(j) for j in range(1, 6)])
    ss = to_statespace(ml)
    target = pulse(3)
    assert rel_err(ss.respond(target.F), ml.predict(target)) < 1e-8
    M, K, C = (X.toarray() for X in (beam.M, beam.K, beam.C))
    S = beam.sensor_matrix().toarray()
    truth = _truth_modes(M, C, K, dt)
    truth = ModeSet(truth.poles, S @ truth.shapes, tuple(str(i) for i in range(6)))
    table = match_modes(ss.modes(), truth.subset(truth.frequency_hz < 1000.0))
    assert len(table) == 6 and table["identified"].notna().all()
    assert np.max(np.abs(table["frequency_error_pct"])) < 1e-6
    assert np.max(np.abs(table["damping_error_rel"])) < 1e-6
    assert table["mac"].min() > 1 - 1e-9


def test_forms_without_a_state_space_are_refused_with_the_reason():
    from types import SimpleNamespace

    parts = SimpleNamespace(modes_=np.eye(2), parts_=[], abbreviation="MDS+ML")
    with pytest.raises(InputError, match="superposition"):
        to_statespace(parts)
    delay = SimpleNamespace(modes_=np.eye(2), model_=(np.eye(2), np.eye(2)), delays=2,
                            abbreviation="OpInf")
    with pytest.raises(InputError, match="delay coordinates"):
        to_statespace(delay)


def test_a_pole_held_once_per_input_is_one_mode_shaped_by_its_residue():
    """A pole model fitted per input holds each pole once per input, with another output
    shape per input (a residue of rank 2). Without the input map eig's copies are two modes
    of arbitrary shapes; with it one mode per pole whose shape is the first left singular
    vector of the residue, here computed independently as lim (z − z_k) C (zI − A)⁻¹ B."""
    dt, rng = 0.01, np.random.default_rng(3)
    s = np.array([-0.3 + 2j * np.pi * 4.0, -2.0 + 2j * np.pi * 11.0])
    blocks, cols, feeds = [], [], []
    for i in range(2):  # per input, one 2 × 2 block per pole, its own output shape
        for sk in s:
            z = np.exp(sk * dt)
            blocks.append(np.array([[z.real, -z.imag], [z.imag, z.real]]))
            cols.append(np.column_stack([rng.standard_normal(3), np.zeros(3)]))
            feeds.append((i, np.array([1.0, 0.0])))
    A = scipy.linalg.block_diag(*blocks)
    C = np.hstack(cols)
    B = np.zeros((A.shape[0], 2))
    for j, (i, b) in enumerate(feeds):
        B[2 * j:2 * j + 2, i] = b
    T = rng.standard_normal(A.shape)  # any basis: the answer must not depend on it
    A, B, C = np.linalg.solve(T, A @ T), np.linalg.solve(T, B), C @ T
    plain = discrete_modes(A, C, dt)
    assert len(plain) == 4  # each pole twice
    one = discrete_modes(A, C, dt, B=B)
    assert len(one) == 2 and any("merged" in n for n in one.notes)
    np.testing.assert_allclose(np.sort_complex(one.poles), np.sort_complex(s), rtol=1e-10)
    eta = 1e-7
    for sk in s:
        zk = np.exp(sk * dt)
        R = eta * C @ np.linalg.solve((zk + eta) * np.eye(A.shape[0]) - A, B)
        expected = np.linalg.svd(R)[0][:, :1]
        j = int(np.argmin(np.abs(one.poles - sk)))
        assert mac(one.shapes[:, j:j + 1], expected)[0, 0] > 1 - 1e-5


def _diagonal_fit(kind: str, U, poles, residues, dt: float, n: int = 200):
    """A fitted diagonal method as the realization reads it (SL's and MR's ``kernel_``,
    POVR's ``Phi_``): POC ``i``'s kernel (free decay) is ``Σ_j 2 Re(a_ij λ_j^(p−1))`` at lag
    ``p ≥ 1`` (free: ``Σ_j 2 Re(a_ij λ_j^t)``), the transfer function ``Σ_j a_ij / (z − λ_j)``;
    a zero residue leaves the pole out of that POC."""
    from types import SimpleNamespace

    lam = np.exp(np.asarray(poles) * dt)
    k = U.shape[1]
    t = np.arange(n)
    seq = np.zeros((n, k, k))
    for i in range(k):
        seq[:, i, i] = 2.0 * np.real((residues[i][None, :] * lam[None, :] ** t[:, None]).sum(1))
    if kind == "free":  # Phi_[t] = Φ(t_t) = C A^t B
        return SimpleNamespace(Phi_=seq, modes_=U, dt_=dt, excitation="displacement",
                               abbreviation="POVR")
    kernel = np.zeros((k, k, n + 1))  # h[p] = Δt kernel[:, :, p], h[0] = D = 0
    kernel[:, :, 1:] = seq.transpose(1, 2, 0) / dt
    return SimpleNamespace(kernel_=kernel, modes_=U, dt_=dt, coupled=False, abbreviation="SL")


@pytest.mark.parametrize("kind", ["forced", "free"])
def test_a_pole_in_two_diagonal_blocks_is_one_mode_shaped_by_the_dominant_residue(kind):
    """SL's, MR's and POVR's diagonal realizations: a pole that two POCs' kernels both hold
    (their assumption broken: the POMs are not the normal modes) is one mode of the model,
    its shape the first left singular vector of the model's residue at that pole, computed
    here independently as lim (z − λ) C (zI − A)⁻¹ B (forced) or the same with ``x0_map``
    (free); without the input map the realization shows it twice, once per POM. Poles only
    one POC holds keep that POM's shape."""
    dt, rng = 0.01, np.random.default_rng(5)
    U = np.linalg.qr(rng.normal(size=(4, 2)))[0]
    s = 2j * np.pi * np.array([4.0, 11.0, 7.0]) * np.sqrt(1 - 0.01**2) - 0.01 * 2 * np.pi \
        * np.array([4.0, 11.0, 7.0])
    # POC 1 holds 4 and 11 Hz, POC 2 holds 4 and 7 Hz; the 4-Hz residues differ in size
    # and phase (0.8 against 0.3: POM 1 dominates the shared pole)
    res = [np.array([0.8 * np.exp(0.4j), 0.5, 0.0]), np.array([0.3 * np.exp(-1.1j), 0.0, 0.6])]
    ss = to_statespace(_diagonal_fit(kind, U, s, res, dt))
    assert ss.order == 8, ss.realization
    every = ss.all_modes()  # eig alone: the 4-Hz pole twice, shaped by POM 1 and POM 2
    assert np.sum(np.abs(every.frequency_hz - 4.0) < 0.01) == 2
    modes = ss.modes()
    assert len(modes) == 3 and any("merged" in n for n in modes.notes)
    np.testing.assert_allclose(np.sort(modes.frequency_hz),
                               np.sort(np.abs(s) / (2 * np.pi)), rtol=1e-9)
    B = ss.B if kind == "forced" else ss.x0_map
    eta = 1e-7
    for sk, expected in zip(s, (None, U[:, :1], U[:, 1:]), strict=True):
        zk = np.exp(sk * dt)
        R = eta * ss.C @ np.linalg.solve((zk + eta) * np.eye(ss.order) - ss.A, B)
        j = int(np.argmin(np.abs(modes.poles - sk)))
        got = modes.shapes[:, j:j + 1]
        assert mac(got, np.linalg.svd(R)[0][:, :1])[0, 0] > 1 - 1e-6
        if expected is not None:  # a pole one POC holds: that POM's shape
            assert mac(got, expected)[0, 0] > 1 - 1e-8
    # the shared pole's residue is U diag(a_1, a_2) Uᵀ: its dominant direction is POM 1
    j = int(np.argmin(np.abs(modes.poles - s[0])))
    assert mac(modes.shapes[:, j:j + 1], U[:, :1])[0, 0] > 1 - 1e-8
    # the named variant, every copy a mode: no merge, the copies' shapes eig's basis of the
    # repeated eigenvalue's eigenspace (here mixtures of the two POMs)
    each = ss.modes(copies="each")
    assert not any("merged" in n for n in each.notes)
    assert np.sum(np.abs(each.frequency_hz - 4.0) < 0.01) >= 1
    with pytest.raises(InputError, match="`copies`"):
        ss.modes(copies="first")


def test_distinct_poles_one_millionth_apart_stay_two_modes():
    """Two poles 1e-6 of the spectral radius apart (100 × SAME_POLE_RTOL) are two modes with
    their own shapes ``C ψ``, whatever the input map; copies of one pole are not."""
    dt, rng = 0.01, np.random.default_rng(6)
    z1 = np.exp((-0.2 + 2j * np.pi * 5.0) * dt)
    z2 = z1 + 1e-6 * np.abs(z1) * np.exp(0.3j)
    rot = [np.array([[z.real, -z.imag], [z.imag, z.real]]) for z in (z1, z2)]
    A = scipy.linalg.block_diag(*rot)
    shapes = rng.standard_normal((3, 2))
    C = np.column_stack([shapes[:, 0], np.zeros(3), shapes[:, 1], np.zeros(3)])
    B = rng.standard_normal((4, 2))
    T = rng.standard_normal((4, 4))
    A, B, C = np.linalg.solve(T, A @ T), np.linalg.solve(T, B), C @ T
    two = discrete_modes(A, C, dt, B=B)
    assert len(two) == 2 and not any("merged" in n for n in two.notes)
    np.testing.assert_allclose(np.sort_complex(np.exp(two.poles * dt)),
                               np.sort_complex([z1, z2]), atol=1e-12)
    j = np.argsort(np.abs(np.exp(two.poles * dt) - z1))
    np.testing.assert_allclose(np.diag(mac(two.shapes[:, j], shapes)), 1.0, atol=1e-8)
