"""``podbench methods [NAME]``: the parameters of every built-in method and solver, generated
from their declarations (``_parameter_constraints``, the constructor's defaults, the
docstring's ``Parameters`` section) — the same declarations the checks use."""

from __future__ import annotations

import inspect

import pytest

from podbench import cli
from podbench.errors import InvalidParameterError
from podbench.sysid import registry
from podbench.sysid.deconvolution import available_solvers, get_solver
from podbench.sysid.methods import BUILTIN_METHODS
from podbench.sysid.paramdocs import entries
from podbench.sysid.params import check_param, describe, parameter_docs, parameters

EVERY = {**{e.name: e.cls for e in registry.ENTRIES},
         **{n: get_solver(n) for n in available_solvers()}}


def _expected_lines(cls) -> list[str]:
    """``name (default D): ADMITS`` of every constructor parameter, built from the class's
    signature and its declared constraints, independently of podbench.sysid.params'
    rendering."""
    sig = inspect.signature(cls.__init__)
    out = []
    for p in sig.parameters.values():
        if p.name == "self" or p.kind not in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD):
            continue
        d = p.default
        shown = f"{d:g}" if isinstance(d, float) else repr(d)
        out.append(f"  {p.name} (default {shown}): "
                   f"{describe(cls._parameter_constraints[p.name])}")
    return out


def test_every_builtin_method_and_solver_is_listed():
    assert entries() == EVERY


@pytest.mark.parametrize("name", list(EVERY))
def test_the_help_shows_every_declared_parameter(name, capsys):
    cls = EVERY[name]
    assert cli.main(["methods", name]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"{name}: {cls.__name__} — ")
    lines = out.splitlines()
    expected = _expected_lines(cls)
    assert [ln for ln in lines if ln.startswith("  ") and not ln.startswith("   ")
            and "(default " in ln] == expected
    for p in parameters(cls):  # each one's whole description follows it
        assert p.doc, f"{name}: parameter {p.name} has no description in the docstring"
        i = lines.index(next(e for e in expected if e.startswith(f"  {p.name} (")))
        j = i + 1
        while j < len(lines) and lines[j].startswith("      "):
            j += 1
        assert " ".join(ln.strip() for ln in lines[i + 1:j]) == " ".join(p.doc.split())


def test_what_the_help_says_a_parameter_admits_is_what_the_check_accepts():
    # ML's n_modes: "None or an integer >= 1"; energy of SL "a number in (0, 1]"
    cons = BUILTIN_METHODS["ML"]._parameter_constraints
    assert "None or an integer >= 1" in _expected_lines(BUILTIN_METHODS["ML"])[0]
    assert check_param(None, "n_modes", cons["n_modes"]) is None
    assert check_param(1, "n_modes", cons["n_modes"]) == 1
    with pytest.raises(InvalidParameterError, match="expected an integer >= 1, got 0"):
        check_param(0, "n_modes", cons["n_modes"])
    with pytest.raises(InvalidParameterError, match=r"expected a number in \(0, 1\], got 1.5"):
        BUILTIN_METHODS["SL"](energy=1.5)._validate_params()


def test_without_a_name_every_entry_is_shown_briefly(capsys):
    assert cli.main(["methods"]) == 0
    out = capsys.readouterr().out
    for name, cls in EVERY.items():
        assert f"\n{name}: {cls.__name__} — " in out
    # briefly: ML's n_lags stops after its first sentence
    assert "from lag n_lags on, C(t_s) = 0 for s >= n_lags." in out
    assert "None (default, the dissertation's): no truncation" not in out
    assert max(map(len, out.splitlines())) <= 88


def test_names_are_checked_before_printing(capsys):
    assert cli.main(["methods", "ML", "MLL"]) == 2
    cap = capsys.readouterr()
    assert cap.out == ""
    assert cap.err == ("podbench methods: error: MLL: not a built-in method or solver; did you "
                       "mean 'ML'? (podbench methods lists them)\n")
    assert cli.main(["methods", "multipleload", "TLS"]) == 0  # a class name, another case
    out = capsys.readouterr().out
    assert out.startswith("ML: MultipleLoad") and "\ntls-dt: TruncatedTLS" in out


class _Doc:
    """A class.

    Parameters
    ----------
    a, b : float
        Shared ``text`` with :class:`~podbench.errors.InputError` and
        :func:`numpy.linalg.svd`.

        Second paragraph.
    c : {"x", "y"}
    d
        No type.

    Notes: prose after the section.

    Attributes
    ----------
    e : float
        Not a parameter.
    """


class _Child(_Doc):
    """A subclass.

    Parameters
    ----------
    c : {"x", "y"}
        Now described.
    a : float
    """


def test_the_docstring_parser_reads_numpydoc_parameters():
    assert parameter_docs(_Doc) == {
        "a": "Shared text with InputError and numpy.linalg.svd. Second paragraph.",
        "b": "Shared text with InputError and numpy.linalg.svd. Second paragraph.",
        "d": "No type."}
    # a subclass's description comes first, an undescribed one falls back to the base's
    assert parameter_docs(_Child) == {
        "c": "Now described.",
        "a": "Shared text with InputError and numpy.linalg.svd. Second paragraph.",
        "b": "Shared text with InputError and numpy.linalg.svd. Second paragraph.",
        "d": "No type."}
