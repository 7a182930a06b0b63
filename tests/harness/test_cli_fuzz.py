"""Mutated scenario files (a key dropped, a wrong type, an unknown key, a bad number) give
exit code 2 and one line, never a traceback or an internal error (exit 3)."""

import contextlib
import io
import json
import math
import os
import tempfile
import textwrap
from pathlib import Path

import pytest
import tomllib
from conftest import CHAIN_FREE
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from podbench import cli

BASE = tomllib.loads(textwrap.dedent(CHAIN_FREE.format(name="fuzz")))


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)  # a JSON string is a TOML basic string
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return "{" + ", ".join(f"{json.dumps(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"


def _toml(doc: dict) -> str:
    """A minimal TOML writer: one inline value per top-level key."""
    return "".join(f"{json.dumps(k)} = {_toml_value(v)}\n" for k, v in doc.items())


def _paths(node, prefix=()):
    """Every (path to a container, key or index) of the document."""
    items = node.items() if isinstance(node, dict) else enumerate(node)
    for k, v in items:
        yield (*prefix, k)
        if isinstance(v, (dict, list)):
            yield from _paths(v, (*prefix, k))


PATHS = list(_paths(BASE))
WRONG = ["text", 3, -1.5, True, [1, "a"], {"k": 1}, [], ""]
BAD_NUMBERS = [float("nan"), float("inf"), -1, 0, -0.0, 1e308, 10**12, 0.5, -1e-300]


def _copy(doc):
    return json.loads(json.dumps(doc))


def _at(doc, path):
    for k in path:
        doc = doc[k]
    return doc


mutation = st.one_of(
    st.tuples(st.just("drop"), st.sampled_from(PATHS), st.none()),
    st.tuples(st.just("type"), st.sampled_from(PATHS), st.sampled_from(WRONG)),
    st.tuples(st.just("unknown"), st.sampled_from([(), *[p for p in PATHS
                                                        if isinstance(_at(BASE, p), dict)]]),
              st.sampled_from(["bogus", "titel", "n_sample", "refrence", "location"])),
    st.tuples(st.just("number"), st.sampled_from(
        [p for p in PATHS if isinstance(_at(BASE, p), (int, float))
         and not isinstance(_at(BASE, p), bool)]), st.sampled_from(BAD_NUMBERS)),
)


def _mutate(doc, kind, path, value):
    doc = _copy(doc)
    if kind == "unknown":
        _at(doc, path)[value] = 1.0
        return doc
    parent, key = _at(doc, path[:-1]), path[-1]
    if kind == "drop":
        del parent[key]
    else:
        parent[key] = value
    return doc


# 30 fixed examples by default; FUZZ_N=1500 FUZZ_RANDOM=1 explores further (run twice: clean)
@pytest.mark.heavy
@settings(max_examples=int(os.environ.get("FUZZ_N", "30")), deadline=None,
          derandomize=os.environ.get("FUZZ_RANDOM") is None,
          suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(mutation, min_size=1, max_size=2))
def test_mutated_scenarios_exit_0_or_2_with_one_line_never_a_traceback(mutations):
    doc = BASE
    for kind, path, value in mutations:
        try:
            doc = _mutate(doc, kind, path, value)
        except (KeyError, IndexError, TypeError):  # the first mutation removed the path
            continue
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "fuzz.toml"
        p.write_text(_toml(doc), encoding="utf-8")
        buf = io.StringIO()
        with contextlib.redirect_stderr(buf), contextlib.redirect_stdout(io.StringIO()):
            code = cli.main(["run", str(p), "-q", "--no-cache", "--no-figures",
                             "--out", os.path.join(d, "out")])
        err = buf.getvalue()
    assert code in (0, 2), (mutations, err)
    if code == 2:
        assert err.startswith("podbench run: error:") and err.count("\n") == 1, err
        assert "Traceback" not in err
