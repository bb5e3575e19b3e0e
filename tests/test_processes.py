"""Worker processes end with their parent, whatever kills it (SIGKILL included), and a
``--scheduler`` that is not a Dask scheduler ends in one line and exit status 1 (issue 23, item 7)."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")


def _children(pid: int) -> list[int]:
    out = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                out.append(int(entry.name))
    return out


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state not in ("Z", "X")          # a zombie has ended; only its reaping is left


def _kill_parent_then_watch_workers(argv: list[str], tmp_path, want: int = 2) -> list[int]:
    """Start ``vrlab argv``, wait until it has ``want`` worker processes, SIGKILL it; return the
    workers still alive 20 s later (the deadline is generous: they should end within a second)."""
    proc = subprocess.Popen([sys.executable, "-m", "vrlab", *argv], cwd=tmp_path, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        workers: list[int] = []
        while time.monotonic() < deadline and len(workers) < want:
            assert proc.poll() is None, "the command ended before its workers started: make it longer"
            time.sleep(0.2)
            workers = _children(proc.pid)
        assert len(workers) >= want, workers
        time.sleep(1.0)                                    # let them get busy
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline and any(_alive(w) for w in workers):
            time.sleep(0.2)
        return [w for w in workers if _alive(w)]
    finally:
        if proc.poll() is None:
            proc.kill()
        for w in _children(proc.pid):
            os.kill(w, signal.SIGKILL)


def test_render_workers_die_with_a_sigkilled_parent(tmp_path):
    left = _kill_parent_then_watch_workers(["render", "cornell_box", "--spp", "4096", "--workers", "2",
                                            "--width", "96", "--height", "96", "-o", "out.npy"], tmp_path)
    for w in left:
        os.kill(w, signal.SIGKILL)
    assert not left, f"orphaned render workers: {left}"


def test_lab_workers_die_with_a_sigkilled_parent(tmp_path):
    left = _kill_parent_then_watch_workers(["lab", "--estimators", "mc,antithetic", "--integrand", "sin,exp",
                                            "--n", "1000000,2000000", "--reps", "400", "--workers", "2",
                                            "--no-progress"], tmp_path)
    for w in left:
        os.kill(w, signal.SIGKILL)
    assert not left, f"orphaned lab workers: {left}"


def test_a_worker_without_its_parent_ends(tmp_path):
    """The mechanism itself, in a forked child whose parent is SIGKILLed: vrlab.execution.worker_init."""
    code = ("import os, time, vrlab.execution as E\n"
            "parent = os.getpid()\n"
            "pid = os.fork()\n"
            "if pid == 0:\n"
            "    E.worker_init(parent)\n"
            "    time.sleep(120)\n"
            "    os._exit(0)\n"
            "print(pid, flush=True)\n"
            "time.sleep(120)\n")
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    child = int(proc.stdout.readline())
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline and _alive(child):
        time.sleep(0.1)
    alive = _alive(child)
    if alive:
        os.kill(child, signal.SIGKILL)
    assert not alive


# -- --scheduler that is not (or not yet) a working Dask scheduler ------------------------------------
LAB = ["lab", "--estimators", "mc", "--integrand", "sin", "--n", "64", "--reps", "2", "--no-progress"]
RENDER = ["render", "furnace", "--spp", "2", "--width", "4", "--height", "3"]


@pytest.fixture
def http_server():
    """A plain HTTP server (what a scheduler's dashboard port is) on a free port."""
    import http.server
    import threading

    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, *args):       # the server's log would mix into the CLI's stderr
            pass

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Quiet)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"tcp://127.0.0.1:{server.server_address[1]}"
    server.shutdown()


@pytest.mark.parametrize("command", [LAB, RENDER], ids=["lab", "render"])
def test_an_http_server_is_not_a_scheduler(capsys, monkeypatch, http_server, command):
    pytest.importorskip("distributed")
    from conftest import run_cli

    monkeypatch.setattr("vrlab.cli_args.SCHEDULER_TIMEOUT", 3.0)
    code, out, err = run_cli(capsys, command + ["--scheduler", http_server])
    assert code == 1, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "--scheduler" in lines[0] and http_server in lines[0], err
    assert "Traceback" not in err


@pytest.fixture
def empty_scheduler():
    """A Dask scheduler without workers, in a process of its own."""
    pytest.importorskip("distributed")
    code = ("import asyncio\nfrom distributed import Scheduler\n"
            "async def main():\n"
            "    async with Scheduler(host='127.0.0.1', port=0, dashboard_address=':0') as s:\n"
            "        print(s.address, flush=True)\n"
            "        await asyncio.sleep(300)\n"
            "asyncio.run(main())\n")
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                            text=True)
    try:
        yield proc.stdout.readline().strip()
    finally:
        proc.kill()
        proc.wait()


def test_a_scheduler_without_workers_says_so_and_gives_up(capsys, monkeypatch, empty_scheduler):
    from conftest import run_cli

    monkeypatch.setattr("vrlab.cli_args.WORKER_WAIT", 2.0)
    code, out, err = run_cli(capsys, LAB + ["--scheduler", empty_scheduler])
    assert code == 1, err
    lines = err.strip().splitlines()
    assert "has no workers yet" in lines[0] and "waiting up to 2 s" in lines[0], err
    assert len(lines) == 2 and "no worker joined" in lines[1] and "Traceback" not in err, err


def test_an_unanswering_address_ends_in_one_line(capsys, monkeypatch):
    """An unroutable address: the TCP connect times out (simulated: the sandbox may route it)."""
    pytest.importorskip("distributed")
    import socket

    from conftest import run_cli

    def no_answer(address, timeout=None):
        raise socket.timeout("timed out")
    monkeypatch.setattr(socket, "create_connection", no_answer)
    code, out, err = run_cli(capsys, LAB + ["--scheduler", "tcp://10.255.255.1:8786"])
    lines = err.strip().splitlines()
    assert code == 1 and len(lines) == 1 and "10.255.255.1" in lines[0] and "no answer within 10 s" in lines[0], err
