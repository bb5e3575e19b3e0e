"""Lab sweeps on other executors (local processes, a process pool, a Dask LocalCluster) give the
same table; resumable sweeps (``store=``) after an interruption, a SIGKILL of the CLI or a
Dask worker that dies; the CLI's --store and --scheduler flags and their errors.

Dask tests start their ``LocalCluster`` on 127.0.0.1 and close it; they are skipped when
``dask.distributed`` is not installed."""
import os
import signal
import socket
import sqlite3
import subprocess
import sys
import time
import warnings
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pandas as pd
import pytest

from vrlab import lab
from conftest import run_cli
from vrlab.estimators import MonteCarlo
from vrlab.integrands import Integrand
from vrlab.lab import runner
from vrlab.lab.store import StoreMismatch

ESTIMATORS = ["mc", "antithetic", ("strat", MonteCarlo(), "stratified")]
KEYS = ["estimator", "integrand", "n", "rep"]


def cubic(x):                       # module level: picklable for process pools
    return 3 * x[..., 0] ** 2


CUBIC = Integrand(cubic, [(0, 1)], 1.0, "cubic")


def _sweep(**kw):
    return lab.run(ESTIMATORS, ["exp", CUBIC], [64, 256], 5, rng=11, **kw)


def _same(a: pd.DataFrame, b: pd.DataFrame) -> None:
    """Bit-identical tables apart from the timing column (rows in the same order)."""
    assert list(a[KEYS].itertuples(index=False)) == list(b[KEYS].itertuples(index=False))
    pd.testing.assert_frame_equal(a.drop(columns="seconds"), b.drop(columns="seconds"), check_exact=True)


@pytest.fixture(scope="module")
def reference():
    return _sweep()


def _cluster(n_workers=2):
    distributed = pytest.importorskip("distributed")
    with warnings.catch_warnings():        # "Port 8787 is already in use": it takes another port
        warnings.simplefilter("ignore", UserWarning)
        cluster = distributed.LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                                           host="127.0.0.1", dashboard_address=None)
    return cluster, distributed.Client(cluster, set_as_default=False)


@pytest.fixture(scope="module")
def dask_client():
    cluster, client = _cluster()
    try:
        yield client
    finally:
        client.close()
        cluster.close()


# -- the same numbers on every executor ---------------------------------------------------------
def test_local_processes_and_a_pool_give_the_same_table(reference):
    _same(reference, _sweep(workers=2))
    with ProcessPoolExecutor(2) as pool:
        _same(reference, _sweep(executor=pool))
    assert not np.array_equal(reference["value"], lab.run(ESTIMATORS, ["exp", CUBIC], [64, 256], 5,
                                                          rng=12)["value"])


def test_dask_cluster_gives_the_same_table(reference, dask_client):
    _same(reference, _sweep(executor=dask_client))
    _same(reference, _sweep(executor=dask_client.get_executor()))
    # Dask ships a lambda integrand by cloudpickle: still the numbers of an in-process run
    lam = Integrand(lambda x: 2 * x[..., 0], [(0, 1)], 1.0, "lam")
    _same(lab.run(["mc"], [lam], [64], 3, rng=1), lab.run(["mc"], [lam], [64], 3, rng=1, executor=dask_client))


# -- resumable sweeps --------------------------------------------------------------------------
class Stop(Exception):
    pass


def _count(path) -> int:
    """Repetitions stored in ``path`` (0 while the table does not exist yet)."""
    if not os.path.exists(path):
        return 0
    con = sqlite3.connect(f"file:{path}?mode=ro", uri=True, timeout=10)
    try:
        return con.execute("SELECT COUNT(*) FROM rows").fetchone()[0]
    except sqlite3.OperationalError:           # the tables are not there yet
        return 0
    finally:
        con.close()


def _interrupted(path, after, **kw):
    """Run the sweep into ``path`` and stop it once ``after`` repetitions are stored."""
    def stop(done, total):
        if done >= after:
            raise Stop
    with pytest.raises(Stop):
        _sweep(store=path, progress=stop, **kw)


def test_resume_runs_only_the_missing_units(reference, tmp_path, monkeypatch):
    path = tmp_path / "runs.sqlite"
    _interrupted(path, after=12)
    stored = _count(path)
    assert 12 <= stored < len(reference)
    calls = []
    real = runner._run_block
    monkeypatch.setattr(runner, "_run_block", lambda jobs, task: calls.append(len(task[4])) or real(jobs, task))
    ticks, said = [], []
    again = _sweep(store=path, progress=lambda done, total: ticks.append(done),
                   resumed=lambda stored, total: said.append((stored, total, len(calls))))
    _same(reference, again)
    assert sum(calls) == len(reference) - stored and ticks[0] == stored
    assert said == [(stored, len(reference), 0)]          # once, before any unit ran
    calls.clear()
    _same(reference, _sweep(store=path, workers=2))     # workers are not part of the sweep: a full store
    assert calls == []


def test_resume_on_dask_and_on_local_processes(reference, tmp_path, dask_client):
    path = tmp_path / "runs.sqlite"
    _interrupted(path, after=20, workers=2)
    _same(reference, _sweep(store=path, executor=dask_client))


def test_store_errors_name_store(tmp_path, raises_naming):
    path = tmp_path / "runs.sqlite"
    lab.run(["mc"], ["exp"], [64], 3, rng=1, store=path)
    for kw in ({"reps": 4}, {"rng": 2}, {"ns": [32]}, {"crn": True}, {"chunk": 16}, {"estimators": ["antithetic"]},
               {"integrands": ["sin"]}):
        args = {"estimators": ["mc"], "integrands": ["exp"], "ns": [64], "reps": 3, "rng": 1, **kw}
        with raises_naming(StoreMismatch, "store") as info:
            lab.run(**args, store=path)
        assert "holds a different sweep" in str(info.value)
        key = next(iter(kw))
        assert {"rng": "seed"}.get(key, key) in str(info.value)       # says what differs
    with raises_naming(ValueError, "store"):
        lab.run(["mc"], ["exp"], [64], 3, store=tmp_path / "runs.db")
    with raises_naming(ValueError, "store"):
        lab.run(["mc"], ["exp"], [64], 3, store=tmp_path / "missing" / "runs.sqlite")
    with raises_naming(ValueError, "store"):
        lab.run(["mc"], ["exp"], [64], 3, store=tmp_path)
    with raises_naming(TypeError, "store"):
        lab.run(["mc"], ["exp"], [64], 3, store=3)
    with raises_naming(ValueError, "store"):
        lab.run(["mc"], ["exp"], [64], 3, rng=None, store=tmp_path / "fresh.sqlite")
    (tmp_path / "text.sqlite").write_text("not a database")
    with raises_naming(ValueError, "store"):
        lab.run(["mc"], ["exp"], [64], 3, store=tmp_path / "text.sqlite")
    other = sqlite3.connect(tmp_path / "other.sqlite")
    other.execute("CREATE TABLE t (x)")
    other.close()
    with raises_naming(ValueError, "store"):
        lab.run(["mc"], ["exp"], [64], 3, store=tmp_path / "other.sqlite")
    assert not (tmp_path / "fresh.sqlite").exists()
    with raises_naming(TypeError, "executor"):
        lab.run(["mc"], ["exp"], [64], 3, executor=3)


# -- the command line ---------------------------------------------------------------------------
LAB = ["lab", "--integrand", "exp,sin", "--estimators", "mc,antithetic", "--n", "64,256", "--reps", "4",
       "--seed", "5", "--no-progress"]


def one_line(err, *names):
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("vrlab lab: error: ") and "Traceback" not in err, err
    for name in names:
        assert name in lines[0], (name, lines[0])


def _csv(path):
    """The CSV back, floats exactly (pandas >= 3 reads them so by default)."""
    exact = {} if int(pd.__version__.split(".")[0]) >= 3 else {"float_precision": "round_trip"}
    return pd.read_csv(path, **exact)


def test_cli_store_resumes_and_refuses_another_sweep(capsys, tmp_path):
    store, a, b = tmp_path / "runs.sqlite", tmp_path / "a.csv", tmp_path / "b.csv"
    code, _, err = run_cli(capsys, LAB + ["--store", str(store), "--csv", str(a)])
    assert code == 0 and "resuming" not in err                 # a new store: nothing to resume
    assert _count(store) == 2 * 2 * 2 * 4
    code, _, err = run_cli(capsys, LAB + ["--store", str(store), "--csv", str(b)])
    assert code == 0 and f"resuming: 32 of 32 units already stored in {store}" in err, err
    pd.testing.assert_frame_equal(_csv(a), _csv(b), check_exact=True)     # all from the store, timings too
    code, out, err = run_cli(capsys, LAB[:-3] + ["--seed", "6", "--store", str(store)])
    assert code == 2 and out == ""
    one_line(err, "--store", "holds a different sweep", "seed")


@pytest.mark.parametrize("make, flag, code", [
    (lambda d: d / "runs.db", "--store", 2),
    (lambda d: d / "missing" / "runs.sqlite", "--store", 1),
    (lambda d: d, "--store", 2),
    (lambda d: (d / "t.sqlite").write_text("text") and d / "t.sqlite", "--store", 1),
])
def test_cli_bad_store(capsys, tmp_path, make, flag, code):
    path = make(tmp_path)
    got, out, err = run_cli(capsys, LAB + ["--store", str(path)])
    assert got == code and out == ""
    one_line(err, flag)


def test_cli_store_and_csv_must_differ(capsys, tmp_path):
    same = str(tmp_path / "x.sqlite")
    code, _, err = run_cli(capsys, LAB + ["--store", same, "--plot", same])
    assert code == 2
    one_line(err, "--plot")


def test_cli_scheduler_errors(capsys, monkeypatch):
    pytest.importorskip("distributed")
    monkeypatch.setattr("vrlab.lab.run", lambda *a, **k: pytest.fail("the sweep started"))
    with socket.socket() as s:                   # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    for extra, code, names in ((["--scheduler", f"tcp://127.0.0.1:{port}"], 1, ["--scheduler", "cannot reach"]),
                               (["--scheduler", "no port"], 2, ["--scheduler"]),
                               (["--scheduler", "http://127.0.0.1:1"], 2, ["--scheduler"]),
                               (["--scheduler", ""], 2, ["--scheduler"]),
                               (["--scheduler", "127.0.0.1:8786", "--workers", "2"], 2, ["--scheduler", "--workers"])):
        got, out, err = run_cli(capsys, LAB + extra)
        assert got == code and out == "", (extra, err)
        one_line(err, *names)


def test_cli_scheduler_gives_the_local_numbers(capsys, tmp_path, dask_client):
    here, there = tmp_path / "here.csv", tmp_path / "there.csv"
    assert run_cli(capsys, LAB + ["--csv", str(here)])[0] == 0
    address = dask_client.scheduler_info()["address"]
    assert run_cli(capsys, LAB + ["--scheduler", address, "--csv", str(there)])[0] == 0
    pd.testing.assert_frame_equal(_csv(here).drop(columns="seconds"), _csv(there).drop(columns="seconds"),
                                  check_exact=True)


def test_cli_killed_by_sigkill_resumes(tmp_path):
    store, resumed = tmp_path / "runs.sqlite", tmp_path / "resumed.csv"
    # 2 x 8 repetitions of 2**20 evaluations: 4 units of 4 repetitions (UNIT_SAMPLES = 2**22)
    argv = [sys.executable, "-m", "vrlab", "lab", "--integrand", "exp,sin", "--estimators", "mc",
            "--n", str(2**20), "--reps", "8", "--seed", "9", "--no-progress", "--store", str(store)]
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 60
        while _count(store) < 4:
            assert proc.poll() is None, proc.stderr.read()
            assert time.monotonic() < deadline
            time.sleep(0.005)
        proc.send_signal(signal.SIGKILL)
    finally:
        proc.kill()
        proc.wait()
        proc.stderr.close()
    assert proc.returncode == -signal.SIGKILL
    stored = _count(store)
    assert 4 <= stored < 16 and stored % 4 == 0          # whole units only
    subprocess.run(argv + ["--csv", str(resumed)], check=True, capture_output=True)
    assert _count(store) == 16
    fresh = tmp_path / "fresh.csv"                        # an uninterrupted run, through the same CSV
    lab.run(["mc"], ["exp", "sin"], [2**20], 8, rng=9).to_csv(fresh, index=False)
    pd.testing.assert_frame_equal(_csv(resumed).drop(columns="seconds"), _csv(fresh).drop(columns="seconds"),
                                  check_exact=True)


# -- last: a Dask worker dies (its nanny replaces it) -------------------------------------------
def test_a_dask_worker_that_dies_mid_sweep(dask_client):
    """Last of the Dask tests: the killed worker's nanny starts a new one."""
    client = dask_client
    big = dict(estimators=["mc", "antithetic"], integrands=["exp", "sin"], ns=[2**17], reps=8, rng=3)
    want = lab.run(**big)
    victim = sorted(client.scheduler_info()["workers"])[0]
    pid = client.run(os.getpid, workers=[victim])[victim]
    killed = []

    def kill_after_first(done, total):
        if not killed and done:
            os.kill(pid, signal.SIGKILL)         # the worker process dies; its nanny starts another
            killed.append(done)

    got = lab.run(**big, executor=client, progress=kill_after_first)
    _same(want, got)
    assert killed and killed[0] < len(want) // 2       # it died with most of the sweep to do
    deadline = time.monotonic() + 20
    while victim in client.scheduler_info()["workers"] and time.monotonic() < deadline:
        time.sleep(0.05)
    assert victim not in client.scheduler_info()["workers"]
