"""Loading structure files: lookup, registry, and one clear error per malformed file."""

from pathlib import Path

import numpy as np
import pytest

from podbench.core.resources import bundled_structures
from podbench.errors import StructureFileError, UnknownNameError
from podbench.structures import build_structure, list_structures, load_structure
from podbench.structures.files import KINDS, structure_dirs

REPO_STRUCTURES = bundled_structures()

BEAM = """\
# Units: inch, lbf, second
name = "{name}"
kind = "cantilever_beam"
units = "inch, lbf, second"
description = "test beam"

[beam]
length = 24.0
width = 1.0
depth = 0.75
E = 29.0e6
density_lbm_per_ft3 = 500.0
n_elements = {n}
"""


def write(tmp_path, text, name="foo"):
    p = tmp_path / f"{name}.toml"
    p.write_text(text, encoding="utf-8")
    return p


def test_shipped_files_are_listed_and_load():
    names = list_structures()
    for n in ("lti_beam", "ltv_beam", "nl_beam"):
        assert n in names
        s = load_structure(n)
        assert s.name == n and Path(s.source) == REPO_STRUCTURES / f"{n}.toml"
        assert s.metadata["units"] == "inch, lbf, second"
        assert "0.0238" in s.description or n != "lti_beam"


def test_every_shipped_file_states_units_at_the_top():
    for p in REPO_STRUCTURES.rglob("*.toml"):
        first = p.read_text(encoding="utf-8").splitlines()[0]
        assert first.startswith("# Units: inch, lbf, second"), p


def test_path_and_search_path_and_env(tmp_path, monkeypatch):
    p = write(tmp_path, BEAM.format(name="mybeam", n=4), name="mybeam")
    assert load_structure(p).n_dofs == 8
    assert load_structure(str(p)).n_dofs == 8
    assert load_structure("mybeam", search_path=[tmp_path]).n_dofs == 8
    assert "mybeam" in list_structures(search_path=tmp_path)
    with pytest.raises(UnknownNameError, match="mybeam"):
        load_structure("mybeam")
    monkeypatch.setenv("PODBENCH_STRUCTURES", str(tmp_path))
    assert structure_dirs()[0] == tmp_path
    assert load_structure("mybeam").n_dofs == 8


def test_unknown_name_lists_available():
    with pytest.raises(UnknownNameError, match=r"no_such_beam.*available:.*lti_beam"):
        load_structure("no_such_beam")


def test_build_from_dict_matches_file():
    import tomllib

    p = REPO_STRUCTURES / "lti_beam.toml"
    spec = tomllib.loads(p.read_text(encoding="utf-8"))
    a = build_structure(spec)
    b = load_structure("lti_beam")
    np.testing.assert_array_equal(a.K.toarray(), b.K.toarray())
    assert a.source == "" and a.name == "lti_beam"


def test_registry_has_all_kinds():
    assert {"cantilever_beam", "satellite_truss", "chain", "matrices", "python"} <= set(KINDS)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        (BEAM.format(name="foo", n=-3),
         r"foo\.toml: field `beam\.n_elements`: expected a positive integer, got -3$"),
        (BEAM.format(name="foo", n='"24"'),
         r"field `beam\.n_elements`: expected a positive integer, got \"24\" \(string\)"),
        (BEAM.format(name="foo", n=2.5),
         r"field `beam\.n_elements`: expected a positive integer, got 2\.5 \(float\)"),
        (BEAM.format(name="foo", n=24).replace("length", "lenght"),
         r"field `beam\.length`: missing .*; is `beam\.lenght` a misspelling\?"),
        (BEAM.format(name="foo", n=24) + "lenght = 3.0\n",
         r"field `beam\.lenght`: unknown field; did you mean `length`\?"),
        (BEAM.format(name="foo", n=24).replace("length = 24.0\n", ""),
         r"field `beam\.length`: missing"),
        (BEAM.format(name="foo", n=24) + "colour = 'red'\n",
         r"field `beam\.colour`: unknown field"),
        (BEAM.format(name="foo", n=24).replace('description = "test beam"',
                                               'description = "x"\nextra = 1'),
         r"field `extra`: unknown field"),
        (BEAM.format(name="foo", n=24).replace('"cantilever_beam"', '"cantilever"'),
         r'field `kind`: unknown kind "cantilever"; known kinds: .*cantilever_beam'),
        (BEAM.format(name="foo", n=24).replace('"inch, lbf, second"', '"mm, N, s"'),
         r'field `units`: expected "inch, lbf, second" \(the dissertation\'s\) or "m, N, second" '
         r'\(SI: m, N, kg, Pa\), got "mm, N, s"'),
        (BEAM.format(name="bar", n=24),
         r'field `name`: "bar" does not match the file name "foo\.toml"'),
        (BEAM.format(name="foo", n=24).replace("E = 29.0e6", "E = -1.0"),
         r"field `beam\.E`: expected a positive number, got -1\.0"),
        (BEAM.format(name="foo", n=24).replace("E = 29.0e6", "E = nan"),
         r"field `beam\.E`: expected a finite positive number"),
        (BEAM.format(name="foo", n=24) + "density = 7e-4\n",
         r"field `beam\.density_lbm_per_ft3`: give only one of"),
        (BEAM.format(name="foo", n=24).replace("[beam]", "beam = 3\n[beem]"),
         r"field `beam`: expected a table"),
        (BEAM.format(name="foo", n=24).replace("n_elements =", "n_elements"),
         r"foo\.toml: TOML syntax error: .*line 13"),
        (BEAM.format(name="foo", n=24) + "[tip_mass]\nlaw = 'sine'\nmean = 1.0\namplitude = 2.0"
         "\nperiod = 0.05\n",
         r"field `tip_mass\.amplitude`: \|amplitude\| = 2\.0 exceeds mean"),
        (BEAM.format(name="foo", n=24) + "[tip_mass]\nlaw = 'constant'\nvalue = 1.0"
         "\nperiod = 0.05\n",
         r"field `tip_mass\.period`: unknown field"),
        (BEAM.format(name="foo", n=24) + "[tip_mass]\nlaw = 'cubic'\n",
         r"field `tip_mass\.law`: expected one of 'constant', 'sine', 'linear'"),
        (BEAM.format(name="foo", n=24) + "[tip_spring]\n",
         r"field `tip_spring\.k3`: missing: give one of"),
    ],
)
def test_malformed_beam_files(tmp_path, text, match):
    with pytest.raises(StructureFileError, match=match):
        load_structure(write(tmp_path, text))


def test_missing_file_is_named(tmp_path):
    with pytest.raises(StructureFileError, match="nope.toml: no such structure file"):
        load_structure(tmp_path / "nope.toml")


CHAIN = """\
# Units: inch, lbf, second
name = "foo"
kind = "chain"
units = "inch, lbf, second"
description = "test chain"

[chain]
n = 3
{body}
"""


@pytest.mark.parametrize(
    ("body", "match"),
    [
        ("masses = [1.0, 2.0]\nsprings = 1.0",
         r"field `chain\.masses`: expected 3 values \(one per mass, n = 3\), got 2"),
        ("masses = 1.0\nsprings = [1.0, 2.0, 3.0]\nboundary = 'fixed-fixed'",
         r"field `chain\.springs`: expected 4 values \(a fixed-fixed chain of n = 3"),
        ("masses = [1.0, -2.0, 1.0]\nsprings = 1.0",
         r"field `chain\.masses\[1\]`: expected a positive number, got -2\.0"),
        ("masses = 'heavy'\nsprings = 1.0",
         r"field `chain\.masses`: expected a number or a non-empty array"),
        ("masses = 1.0\nsprings = 1.0\nmass_coupling = 0.7",
         r"field `chain\.mass_coupling`: expected \|μ\| < 0\.5"),
        ("masses = 1.0\nsprings = 1.0\n[damping]\ntype = 'dashpots'\n"
         "dashpots = [{dofs = [0, 3], c = 1.0}]",
         r"field `damping\.dashpots\[0\]\.dofs`: DOF 3 outside \[0, 2\]"),
        ("masses = 1.0\nsprings = 1.0\n[damping]\ntype = 'dashpots'\n"
         "dashpots = [{dofs = [0], c = 1.0, k = 2.0}]",
         r"field `damping\.dashpots\[0\]\.k`: unknown field"),
        ("masses = 1.0\nsprings = 1.0\n[damping]\ntype = 'rayleigh'\nalpha = 0.1",
         r"field `damping\.beta`: missing"),
        ("masses = 1.0\nsprings = 1.0\n[damping]\ntype = 'modal'",
         r"field `damping\.type`: expected one of 'none', 'rayleigh', 'dashpots'"),
        ("masses = 1.0\nsprings = 1.0\n[damping]\ntype = 'none'\nalpha = 0.1",
         r"field `damping\.alpha`: unknown field"),
    ],
)
def test_malformed_chain_files(tmp_path, body, match):
    with pytest.raises(StructureFileError, match=match):
        load_structure(write(tmp_path, CHAIN.format(body=body)))


def test_malformed_truss_files(tmp_path):
    text = (REPO_STRUCTURES / "satellite_truss.toml").read_text(encoding="utf-8")
    text = text.replace('name = "satellite_truss"', 'name = "foo"')
    cases = [
        (text.replace("element = 10 ", "element = 51 "),
         r"field `fracture\.element`: expected an integer <= 50, got 51"),
        (text.replace("thickness = 0.04 ", "thickness = 2.0 "),
         r"field `truss\.longeron\.thickness`: 2\.0 in exceeds half the outer diameter"),
        (text.replace("[truss.batten]", "[truss.battens]"),
         r"field `truss\.batten`: missing"),
        (text.replace('supports = "pinned"', 'supports = "clamped"'),
         r"field `truss\.supports`: expected one of 'pinned', 'free'"),
        (text.replace("time = 3.0 ", "time = -3.0 "),
         r"field `fracture\.time`: expected a non-negative number, got -3\.0"),
    ]
    assert load_structure(write(tmp_path, text)).n_dofs == 299
    for bad, match in cases:
        assert bad != text
        with pytest.raises(StructureFileError, match=match):
            load_structure(write(tmp_path, bad))


# ---------------------------------------------------------------------------- definiteness
def _matrices_file(tmp_path, **arrays):
    np.savez(tmp_path / "sys.npz", **arrays)
    return write(tmp_path, '# Units: inch, lbf, second\nname = "foo"\nkind = "matrices"\n'
                 'units = "inch, lbf, second"\ndescription = "test"\n\n[matrices]\n'
                 'file = "sys.npz"\nsensor_dofs = "all"\n')


def test_an_indefinite_stiffness_is_refused_at_load_naming_file_field_and_eigenvalue(tmp_path):
    # K = [[2, -3], [-3, 2]] has eigenvalues -1 and 5: indefinite
    p = _matrices_file(tmp_path, M=np.eye(2), K=np.array([[2.0, -3.0], [-3.0, 2.0]]))
    with pytest.raises(StructureFileError) as e:
        load_structure(p)
    msg = str(e.value)
    assert "foo.toml: field `matrices.file`: matrix K" in msg and "\n" not in msg
    assert "not positive semi-definite (smallest eigenvalue -1," in msg


def test_an_indefinite_damping_matrix_and_a_builder_result_are_refused(tmp_path):
    p = _matrices_file(tmp_path, M=np.eye(2), K=np.eye(2), C=np.diag([1.0, -0.5]))
    with pytest.raises(StructureFileError, match=r"matrix C .*smallest eigenvalue -0\.5"):
        load_structure(p)
    (tmp_path / "bad_builder.py").write_text(
        "import numpy as np\n"
        "def build():\n    return {'M': np.eye(3), 'K': -np.eye(3)}\n")
    q = write(tmp_path, '# Units: inch, lbf, second\nname = "foo"\nkind = "python"\n'
              'units = "inch, lbf, second"\ndescription = "test"\n'
              'builder = "bad_builder:build"\npath = "bad_builder.py"\n')
    with pytest.raises(StructureFileError,
                       match=r"foo\.toml: bad_builder:build returned K: not positive "
                             r"semi-definite \(smallest eigenvalue -1"):
        load_structure(q)


def test_singular_stiffness_passes_and_the_shipped_structures_are_definite(tmp_path):
    # a free-free spring (rigid-body mode, eigenvalues 0 and 2e6): semi-definite is enough
    p = _matrices_file(tmp_path, M=np.eye(2), K=1e6 * np.array([[1.0, -1.0], [-1.0, 1.0]]))
    assert load_structure(p).n_dofs == 2
    for name in ("satellite_truss", "lti_beam", "ltv_beam", "nl_beam", "chain_coupled"):
        load_structure(name)  # the truss's K after the fracture is singular: it passes


@pytest.mark.heavy
def test_sparse_definiteness_check_agrees_with_the_eigenvalues():
    import scipy.sparse as sp

    from podbench.errors import InputError
    from podbench.structures.chain import chain
    from podbench.structures.matrices import check_definite

    n = 1200  # above the dense limit: the sparse LDLᵀ inertia decides
    K = chain(n, boundary="fixed-free").K
    check_definite(K, "K", semi=True)
    check_definite(K, "K", semi=False)
    free = K.tolil()
    free[0, 0] = 1.0  # ungrounded: singular, eigenvalue 0
    check_definite(free.tocsr(), "K", semi=True)
    with pytest.raises(InputError, match="not positive definite"):
        check_definite(free.tocsr(), "K", semi=False)
    # two eigenvalues pushed below zero: the inertia counts them
    bad = (free - sp.diags(np.r_[np.zeros(n - 2), 5.0, 5.0])).tocsr()
    lam = np.linalg.eigvalsh(bad.toarray())
    assert (lam < 0).sum() == 2
    with pytest.raises(InputError, match=r"K: not positive semi-definite \(2 eigenvalue\(s\)"):
        check_definite(bad, "K", semi=True)
