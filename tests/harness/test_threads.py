"""BLAS thread pinning: tables do not depend on the caller's BLAS threads (or on --jobs)."""

import threading

import pytest
from conftest import CHAIN_FORCED
from threadpoolctl import threadpool_info, threadpool_limits

from podbench.core.threads import single_blas_thread
from podbench.harness.runner import run_study
from podbench.harness.sweep import run_sweep
from podbench.harness.tables import summary_table

# ML with truncated TLS: its SVD differs in the last bits between 1 and 2 OpenBLAS threads
# (measured on the 2-core CI machine before pinning: every row of this sweep differed).
TLS_SWEEP = CHAIN_FORCED + '\n[sweep]\nnoise = [0.0]\nseeds = [0]\nsolvers = ["tls-dt"]\n'


def _blas_threads() -> list[int]:
    return [d["num_threads"] for d in threadpool_info() if d["user_api"] == "blas"]


def test_single_blas_thread_pins_and_restores_the_callers_limits():
    with threadpool_limits(limits=2):
        assert set(_blas_threads()) == {2}
        with single_blas_thread():
            assert set(_blas_threads()) == {1}
            with single_blas_thread():  # re-entrant
                assert set(_blas_threads()) == {1}
            assert set(_blas_threads()) == {1}
        assert set(_blas_threads()) == {2}
        with pytest.raises(KeyError), single_blas_thread():
            raise KeyError("x")
        assert set(_blas_threads()) == {2}


def test_threads_of_one_process_keep_the_pin_until_the_last_leaves():
    inside, release, seen = threading.Event(), threading.Event(), []

    def long_task():
        with single_blas_thread():
            inside.set()
            release.wait(10)
            seen.append(set(_blas_threads()))

    with threadpool_limits(limits=2):
        t = threading.Thread(target=long_task)
        t.start()
        inside.wait(10)
        with single_blas_thread():  # a short task that ends first must not un-pin the other
            pass
        release.set()
        t.join(10)
        assert seen == [{1}] and set(_blas_threads()) == {2}


def test_serial_results_do_not_depend_on_the_callers_blas_threads(write_scenario):
    p = write_scenario(TLS_SWEEP, "chain_tls")
    tables = {}
    for n in (1, 2):
        with threadpool_limits(limits=n):
            _, df = run_sweep([p])
            study = summary_table(run_study([p]))
            assert set(_blas_threads()) == {n}  # the caller's limits are restored
        # full precision (repr), not the 6 digits of summary.csv: byte-for-byte
        tables[n] = (df.to_csv(float_format="%.17g"), study.to_csv(float_format="%.17g"))
    assert tables[1] == tables[2]
