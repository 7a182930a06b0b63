"""The one executor of units, sweep points and figures: order, progress, errors, cancel."""

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from podbench.errors import InputError, ScenarioFileError
from podbench.harness import executor
from podbench.harness.executor import MAX_AUTO_JOBS, execute, resolve_jobs

pytestmark = pytest.mark.heavy  # seconds per test: not in the fast tier (README)


def _square(x):
    time.sleep(0.05 * (x % 3))  # finish out of order
    return x * x


def _fail_first(task):
    i, folder = task
    if i == 0:
        raise ScenarioFileError("scenario.toml: field `scenario.dt`: expected > 0")
    time.sleep(1.0)
    open(os.path.join(folder, f"{i}.ran"), "w").close()
    return i


def _zero_division(x):
    return 1 / x


def _pid_after(seconds):
    time.sleep(seconds)
    return os.getpid()


@pytest.mark.parametrize("jobs", [1, 2])
@pytest.mark.usefixtures("pool_at_once")
def test_results_in_task_order_and_progress_per_finished_task(jobs):
    seen = []
    out = execute(_square, range(7), jobs=jobs,
                  progress=lambda done, total, elapsed, r: seen.append((done, total, r)))
    assert out == [x * x for x in range(7)]
    assert [d for d, _, _ in seen] == list(range(1, 8)) and {t for _, t, _ in seen} == {7}
    assert sorted(r for *_, r in seen) == sorted(out)


@pytest.mark.usefixtures("pool_at_once")
def test_first_podbench_error_is_raised_as_itself_and_pending_tasks_are_cancelled(tmp_path):
    tasks = [(i, str(tmp_path)) for i in range(20)]
    with pytest.raises(ScenarioFileError) as info:
        execute(_fail_first, tasks, jobs=2)
    assert str(info.value) == "scenario.toml: field `scenario.dt`: expected > 0"
    assert info.value.__cause__ is None and info.value.__suppress_context__
    # the running tasks finish, the queued ones never start (without cancellation all 19
    # would run: 10 s)
    ran = len(list(tmp_path.glob("*.ran")))
    assert ran < 10, ran


@pytest.mark.usefixtures("pool_at_once")
def test_other_worker_errors_carry_the_worker_traceback():
    with pytest.raises(RuntimeError, match=r"(?s)_zero_division.*ZeroDivisionError"):
        execute(_zero_division, [1, 0, 2], jobs=2)
    with pytest.raises(ZeroDivisionError):  # in the caller's process: the original
        execute(_zero_division, [1, 0, 2], jobs=1)


@pytest.mark.parametrize("jobs", [0, -1, 1.5, True, "2"])
def test_jobs_must_be_a_positive_integer(jobs):
    with pytest.raises(InputError, match="jobs"):
        execute(_square, [1], jobs=jobs)


def test_the_caller_computes_and_workers_join_only_after_pool_after(monkeypatch):
    # short tasks: all done before POOL_AFTER, so no process is spawned
    assert set(execute(_pid_after, [0.01] * 4, jobs=2)) == {os.getpid()}
    # longer work: a worker joins the calling process; each task ran exactly once
    monkeypatch.setattr(executor, "POOL_AFTER", 0.2)
    pids = execute(_pid_after, [0.5] * 8, jobs=2)
    assert os.getpid() in pids and len(set(pids)) == 2, pids


def test_costs_hand_out_the_costliest_task_first():
    started = []
    out = execute(lambda x: started.append(x) or -x, [1, 5, 3, 5, 2], jobs=2,
                  costs=[1, 5, 3, 5, 2])
    assert out == [-1, -5, -3, -5, -2]  # results in task order
    assert started == [5, 5, 3, 2, 1]  # handed out largest first (all in the caller here)


def test_auto_is_the_cores_available_capped():
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    assert resolve_jobs("auto") == min(cores, MAX_AUTO_JOBS) >= 1
    assert resolve_jobs(3) == 3
    with pytest.raises(InputError, match="--jobs: expected a positive integer or 'auto'"):
        resolve_jobs("many", "--jobs")


SCRIPT = """\
import os
from podbench.harness import executor
executor.POOL_AFTER = 0.0  # start the workers at once
{body}
"""


def _script(tmp_path, body: str) -> str:
    """Run ``body`` as a plain script ``main.py`` in ``tmp_path`` (its tasks, a module-level
    function, in ``work.py`` beside it); its stdout."""
    (tmp_path / "work.py").write_text(
        "import os, time\n\ndef pid_after(s):\n    time.sleep(s)\n    return os.getpid()\n")
    (tmp_path / "main.py").write_text(SCRIPT.format(body=body))
    root = Path(__file__).resolve().parents[2]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(root), str(tmp_path)]))
    r = subprocess.run([sys.executable, "main.py"], cwd=tmp_path, env=env, capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]
    return r.stdout + r.stderr


def test_a_plain_script_without_a_main_guard_computes_in_its_own_process(tmp_path):
    """Without the guard a spawned worker would run the script again and call `execute`
    while it starts (RuntimeError ... bootstrapping phase, BrokenProcessPool): the tasks run
    in the script's process, once each, with one warning naming the script."""
    out = _script(tmp_path, "import work\npids = executor.execute(work.pid_after, [0.3] * 6, "
                            "jobs=2)\nprint('pids', len(pids), len(set(pids)), "
                            "set(pids) == {os.getpid()})")
    assert "pids 6 1 True" in out, out
    assert out.count("computing in this process alone, not 2 processes") == 1, out
    assert "main.py again" in out and "BrokenProcessPool" not in out


def test_a_guarded_script_still_gets_its_worker_processes(tmp_path):
    out = _script(tmp_path, "import work\nif __name__ == '__main__':\n"
                            "    pids = executor.execute(work.pid_after, [0.3] * 6, jobs=2)\n"
                            "    print('pids', len(pids), len(set(pids)))")
    assert "pids 6 2" in out, out
    assert "process alone" not in out


@pytest.mark.parametrize("source, line, guarded", [
    ("import x\nx.run()\n", 2, False),
    ("import x\nif __name__ == '__main__':\n    x.run()\n", 3, True),
    ('import x\nif "__main__" == __name__:\n    main()\n    other()\n', 4, True),
    ("import x\nif __name__ == '__main__':\n    pass\nx.run()\n", 4, False),
    ("def f():\n    if __name__ == '__main__':\n        run()\n", 3, False),  # not top level
    ("if __name__ != '__main__':\n    run()\n", 2, False),
    ("this is not python(\n", 1, False),
])
def test_guarded_line_reads_the_main_guard(source, line, guarded):
    assert executor.guarded_line(source, line) is guarded
