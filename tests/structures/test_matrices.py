"""User matrices (.npz/.mat/.mtx/.npy) and user builders (kind "python")."""


import numpy as np
import pytest
import scipy.io
import scipy.sparse as sp

from podbench.core.resources import bundled_structures
from podbench.errors import InputError, StructureFileError
from podbench.structures import from_matrices, load_structure

EXAMPLES = bundled_structures() / "examples"


def small_system():
    M = np.array([[2.0, 0.5, 0.0], [0.5, 2.0, 0.5], [0.0, 0.5, 1.0]])
    K = np.array([[300.0, -100.0, 0.0], [-100.0, 200.0, -100.0], [0.0, -100.0, 100.0]])
    C = 0.01 * K + 0.2 * M
    return M, K, C


def toml(name, body):
    return (f'# Units: inch, lbf, second\nname = "{name}"\nkind = "matrices"\n'
            f'units = "inch, lbf, second"\ndescription = "test"\n\n[matrices]\n{body}')


def check_same(s, M, K, C):
    np.testing.assert_array_equal(s.M.toarray(), M)
    np.testing.assert_array_equal(s.K.toarray(), K)
    if C is None:
        assert s.C is None
    else:
        np.testing.assert_array_equal(s.C.toarray(), C)


def test_round_trip_npz(tmp_path):
    M, K, C = small_system()
    np.savez(tmp_path / "sys.npz", M=M, K=K, C=C)
    (tmp_path / "a.toml").write_text(toml("a", 'file = "sys.npz"\nsensor_dofs = [0, 2]\n'))
    s = load_structure(tmp_path / "a.toml")
    check_same(s, M, K, C)
    np.testing.assert_array_equal(s.sensor_dofs, [0, 2])
    assert s.metadata["matrix_sources"] == {"M": "sys.npz", "K": "sys.npz", "C": "sys.npz"}


def test_round_trip_mat_sparse(tmp_path):
    M, K, _ = small_system()
    scipy.io.savemat(tmp_path / "sys.mat", {"M": sp.csc_matrix(M), "K": K})
    (tmp_path / "b.toml").write_text(toml("b", 'file = "sys.mat"\nsensor_dofs = "all"\n'))
    s = load_structure(tmp_path / "b.toml")
    check_same(s, M, K, None)
    np.testing.assert_array_equal(s.sensor_dofs, [0, 1, 2])


def test_round_trip_mtx_and_npy(tmp_path):
    M, K, C = small_system()
    scipy.io.mmwrite(tmp_path / "M.mtx", sp.coo_matrix(M), precision=17)
    scipy.io.mmwrite(tmp_path / "K.mtx", K, precision=17)
    np.save(tmp_path / "C.npy", C)
    (tmp_path / "c.toml").write_text(toml(
        "c", 'M = "M.mtx"\nK = "K.mtx"\nC = "C.npy"\nsensor_dofs = [-1, 1]\n'))
    s = load_structure(tmp_path / "c.toml")
    check_same(s, M, K, C)
    np.testing.assert_array_equal(s.sensor_dofs, [-1, 1])


def test_shipped_example_matches_its_description():
    s = load_structure("examples/user_matrices")
    M = np.diag([0.02, 0.015, 0.01])
    K = np.array([[700.0, -300.0, 0.0], [-300.0, 500.0, -200.0], [0.0, -200.0, 200.0]])
    check_same(s, M, K, 0.05 * M + 1e-4 * K)
    assert s.dof_labels == ("mass0", "mass1", "mass2")


def test_python_builder_example():
    s = load_structure("examples/my_builder")
    assert (s.n_dofs, s.n_sensors) == (4, 4)
    # fixed-base shear building, 4 stories: closed form ω_j = 2√(k/m) sin((2j−1)π/(2(2n+1)))
    j = np.arange(1, 5)
    w = 2 * np.sqrt(500.0 / 0.5) * np.sin((2 * j - 1) * np.pi / 18)
    np.testing.assert_allclose(s.natural_frequencies(4), w / (2 * np.pi), rtol=1e-10)
    # 2 % damping at the first mode (stiffness-proportional)
    np.testing.assert_allclose(s.C.toarray(), 2 * 0.02 / w[0] * s.K.toarray(), rtol=1e-12)
    assert s.name == "my_builder" and s.source.endswith("my_builder.toml")


PY_HEAD = ('# Units: inch, lbf, second\nname = "{name}"\nkind = "python"\n'
           'units = "inch, lbf, second"\ndescription = "test"\n')


def test_python_builder_returning_structure(tmp_path):
    (tmp_path / "b.py").write_text(
        "from podbench.fem.chain import chain\n"
        "def make(n):\n    return chain(n, masses=2.0, springs=8.0)\n")
    (tmp_path / "pb.toml").write_text(
        PY_HEAD.format(name="pb") + 'builder = "b:make"\npath = "b.py"\n[parameters]\nn = 3\n')
    s = load_structure(tmp_path / "pb.toml")
    assert s.name == "pb" and s.n_dofs == 3 and s.description == "test"


@pytest.mark.parametrize(
    ("files", "body", "match"),
    [
        ({}, 'file = "none.npz"\nsensor_dofs = "all"\n',
         r"field `matrices\.file`: no such file"),
        ({"sys.npz": dict(M=np.eye(2))}, 'file = "sys.npz"\nsensor_dofs = "all"\n',
         r'field `matrices\.file`: "sys\.npz" holds no matrix "K"'),
        ({"sys.npz": dict(M=np.eye(2), K=np.eye(3))}, 'file = "sys.npz"\nsensor_dofs = "all"\n',
         r"d\.toml: field `matrices\.file`: matrix K in \"sys\.npz\": expected shape \(2, 2\)"),
        ({"sys.npz": dict(M=np.eye(2), K=np.array([[1.0, 2.0], [0.0, 1.0]]))},
         'file = "sys.npz"\nsensor_dofs = "all"\n',
         r"matrix K in \"sys\.npz\": not symmetric"),
        ({"sys.npz": dict(M=np.diag([1.0, -1.0]), K=np.eye(2))},
         'file = "sys.npz"\nsensor_dofs = "all"\n',
         r"matrix M in \"sys\.npz\": not positive definite \(smallest eigenvalue -1"),
        ({"sys.npz": dict(M=np.eye(2), K=np.array([[1.0, np.nan], [np.nan, 1.0]]))},
         'file = "sys.npz"\nsensor_dofs = "all"\n', r"matrix K .*NaN or Inf"),
        ({"sys.npz": dict(M=np.eye(2), K=np.eye(2), X=np.eye(2))},
         'file = "sys.npz"\nsensor_dofs = "all"\n', r'unexpected array "X"'),
        ({"sys.npz": dict(M=np.eye(2), K=np.eye(2))}, 'file = "sys.npz"\nsensor_dofs = [0, 2]\n',
         r"field `matrices\.sensor_dofs`: DOF 2 outside \[-1, 1\]"),
        ({"sys.npz": dict(M=np.eye(2), K=np.eye(2))}, 'file = "sys.npz"\nsensor_dofs = "some"\n',
         r"field `matrices\.sensor_dofs`: expected \"all\""),
        ({"sys.npz": dict(M=np.eye(2), K=np.eye(2))}, 'file = "sys.npz"\n',
         r"field `matrices\.sensor_dofs`: missing"),
        ({"sys.npz": dict(M=np.eye(2), K=np.eye(2))},
         'file = "sys.npz"\nM = "x.mtx"\nsensor_dofs = "all"\n',
         r"field `matrices\.M`: give only one of `matrices\.file`, `matrices\.M`"),
        ({"sys.npz": dict(M=np.eye(2), K=np.eye(2))},
         'file = "sys.npz"\nsensor_dofs = "all"\ndof_labels = ["a"]\n',
         r"field `matrices\.dof_labels`: expected 2 labels"),
        ({"obj.npz": dict(M=np.array([{"a": 1}], dtype=object), K=np.eye(1))},
         'file = "obj.npz"\nsensor_dofs = "all"\n',
         r"field `matrices\.file`: cannot read .*pickle"),
        ({"M.txt": None}, 'M = "M.txt"\nK = "M.txt"\nsensor_dofs = "all"\n',
         r"field `matrices\.M`: .*unsupported matrix file type \"\.txt\""),
    ],
)
def test_bad_matrix_files(tmp_path, files, body, match):
    for fname, arrays in files.items():
        if arrays is None:
            (tmp_path / fname).write_text("1 2\n3 4\n")
        else:
            np.savez(tmp_path / fname, **arrays)
    (tmp_path / "d.toml").write_text(toml("d", body))
    with pytest.raises(StructureFileError, match=match):
        load_structure(tmp_path / "d.toml")


@pytest.mark.parametrize(
    ("extra", "pyfile", "match"),
    [
        ('builder = "b.make"\n', None, r'field `builder`: expected "module:function"'),
        ('builder = "b:make"\npath = "missing.py"\n', None, r"field `path`: no such file"),
        ('builder = "b:nope"\npath = "b.py"\n', "def make():\n    pass\n",
         r'field `builder`: module "b" has no function "nope"'),
        ('builder = "b:make"\npath = "b.py"\n[parameters]\nz = 1\n', "def make(n):\n    pass\n",
         r"field `parameters\.z`: not a parameter of b:make \(its parameters: n\)"),
        ('builder = "b:make"\npath = "b.py"\n', "def make(n):\n    pass\n",
         r"field `parameters`: do not match b:make: missing a required argument: 'n'"),
        ('builder = "b:make"\npath = "b.py"\n', "def make():\n    return 3\n",
         r"must return a Structure or a dict"),
        ('builder = "b:make"\npath = "b.py"\n', "def make():\n    return {'M': 1.0}\n",
         r"returned no 'K'"),
        ('builder = "b:make"\npath = "b.py"\n',
         "import numpy as np\ndef make():\n    return {'M': np.eye(2), 'K': np.eye(2), 'Q': 1}\n",
         r"returned unknown key 'Q'"),
        ('builder = "b:make"\npath = "b.py"\n',
         "import numpy as np\ndef make():\n    return {'M': -np.eye(2), 'K': np.eye(2)}\n",
         r"pe\.toml: b:make returned M: not positive definite"),
        ('builder = "b:make"\npath = "b.py"\n', "def make():\n    raise RuntimeError('boom')\n",
         r"field `builder`: b:make raised RuntimeError: boom"),
        ('builder = "b:make"\npath = "b.py"\n', "def make(:\n",
         r"field `path`: importing .* failed: SyntaxError"),
        ('builder = "no_such_module_xyz:make"\n', None,
         r'field `builder`: cannot import module "no_such_module_xyz"'),
    ],
)
def test_bad_python_builders(tmp_path, extra, pyfile, match):
    if pyfile is not None:
        (tmp_path / "b.py").write_text(pyfile)
    (tmp_path / "pe.toml").write_text(PY_HEAD.format(name="pe") + extra)
    with pytest.raises(StructureFileError, match=match):
        load_structure(tmp_path / "pe.toml")


def test_from_matrices_python_api():
    M, K, C = small_system()
    s = from_matrices(M=M, K=K, C=C)
    check_same(s, M, K, C)
    with pytest.raises(InputError, match=r"Parameter `K`: not symmetric"):
        from_matrices(M=M, K=K + np.triu(K, 1))
    with pytest.raises(InputError, match=r"Parameter `M`: expected a 2-D matrix"):
        from_matrices(M=np.ones(3), K=K)
    # a tiny asymmetry within the tolerance is accepted and removed
    Kn = K.copy()
    Kn[0, 1] += 1e-12
    s = from_matrices(M=M, K=Kn)
    assert abs(s.K - s.K.T).max() == 0.0
