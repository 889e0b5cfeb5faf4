"""Clean shutdown: each parallel command, stopped by SIGTERM, SIGINT (to its process group,
as Ctrl-C does) or SIGKILL while its pool works, ends within seconds, leaves none of its
processes running and no half-written file."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

psutil = pytest.importorskip("psutil")

ROOT = Path(__file__).resolve().parents[2]
MAIN = "from cml_edge.cli import run; run()"  # the cml-edge program
COMMANDS = {  # each long enough to be running when the signal comes: 20 s or more on two
    # warm workers (a command that has ended by then dies of SIGTERM's default action)
    "scenario": ["scenario", "paper", "--backend", "crossbar", "--seeds", "200", "--out",
                 "{out}"],
    "sweep": ["sweep", "convergence", "--seeds", "1000", "--out", "{out}"],
    "emulate": ["emulate", "--backend", "crossbar", "--chips", "400", "--seeds", "1",
                "--walks", "30", "--chips-out", "{out}"],
    "breakpoint": ["breakpoint", "--knob", "read_noise", "--scenario", "paper", "--backend",
                   "crossbar", "--seeds", "100", "--out", "{out}"],
    "report": ["report", "--quick", "--out", "{out}"],
}
STOP_S = 10  # "within a few seconds", with room for a loaded machine


def _alive(pids):
    out = []
    for pid in pids:
        try:
            if psutil.Process(pid).status() != psutil.STATUS_ZOMBIE:
                out.append(pid)
        except psutil.NoSuchProcess:
            pass
    return out


def _end(proc, workers):
    """Whatever a failed test left running."""
    for pid in _alive(workers):
        os.kill(pid, signal.SIGKILL)
    if proc.poll() is None:
        proc.kill()
        proc.wait()


def _start(argv, tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.Popen([sys.executable, "-c", MAIN, *argv, "--workers", "2"], cwd=tmp_path,
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            start_new_session=True, text=True)


def _workers(proc, n=2, timeout=120):
    """The pids of the command's pool workers, once ``n`` of them run."""
    main = psutil.Process(proc.pid)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        assert proc.poll() is None, proc.stderr.read()
        children = main.children(recursive=True)
        if len(children) >= n:
            time.sleep(0.5)  # let them start their tasks
            return [c.pid for c in main.children(recursive=True)]
        time.sleep(0.2)
    raise AssertionError("the pool did not start")


@pytest.mark.slow
@pytest.mark.parametrize("sig", ["SIGTERM", "SIGINT", "SIGKILL"])
@pytest.mark.parametrize("command", COMMANDS)
def test_a_stopped_command_leaves_no_process(command, sig, tmp_path):
    out = tmp_path / "out"
    proc = _start([a.format(out=out) for a in COMMANDS[command]], tmp_path)
    workers = []
    try:
        workers = _workers(proc)
        t0 = time.monotonic()
        if sig == "SIGINT":  # Ctrl-C: the terminal signals the whole foreground group
            os.killpg(proc.pid, signal.SIGINT)
        else:
            os.kill(proc.pid, getattr(signal, sig))
        code = proc.wait(STOP_S)
        took = time.monotonic() - t0
        deadline = time.monotonic() + 5
        while _alive(workers) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not _alive(workers), f"{command} left {_alive(workers)} after {sig}"
    finally:
        _end(proc, workers)
    err = proc.stderr.read()
    assert took < STOP_S and "Traceback" not in err, err
    if sig == "SIGKILL":
        assert code == -signal.SIGKILL
    else:
        assert code == 128 + getattr(signal, sig), err
        assert err.strip().splitlines()[-1] == (f"cml-edge: stopped by {sig}; nothing was "
                                                f"half-written"), err
    written = [p for p in tmp_path.rglob("*") if p.is_file()]
    temporary = [p for p in written if p.name.startswith(".") or p.suffix == ".tmp"]
    if sig != "SIGKILL":  # a SIGKILLed write may leave its hidden temporary file, never
        assert not temporary, written  # read as a result; its results are whole
    for p in set(written) - set(temporary):
        if p.suffix == ".json":
            json.loads(p.read_text())


def test_a_pool_worker_dies_with_its_parent(tmp_path):
    """The parent of a worker is SIGKILLed: the worker ends within a second or two."""
    code = ("import os, time, sys\n"
            "from concurrent.futures import ProcessPoolExecutor\n"
            "from cml_edge.engine.stop import worker_init\n"
            "pool = ProcessPoolExecutor(1, initializer=worker_init, initargs=(os.getpid(),))\n"
            "pool.submit(time.sleep, 600)\n"
            "time.sleep(600)\n")
    proc = subprocess.Popen([sys.executable, "-c", code], env={**os.environ,
                            "PYTHONPATH": str(ROOT)}, start_new_session=True)
    workers = []
    try:
        workers = _workers(proc, n=1, timeout=60)
        proc.kill()
        proc.wait(5)
        deadline = time.monotonic() + 3
        while _alive(workers) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not _alive(workers)
    finally:
        _end(proc, workers)


@pytest.mark.slow
@pytest.mark.parametrize("sig", ["SIGTERM", "SIGINT"])
def test_a_stopped_training_ends_within_seconds(sig, tmp_path):
    """A command without a pool: stopped between chunks of its compiled loops."""
    proc = subprocess.Popen([sys.executable, "-c", MAIN, "train", "--backend", "crossbar",
                             "--walks", "3000", "--out", tmp_path / "m.npz"], cwd=tmp_path,
                            env={**os.environ, "PYTHONPATH": str(ROOT)},
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        time.sleep(5)  # into the training (or the compilation before it)
        assert proc.poll() is None
        t0 = time.monotonic()
        os.kill(proc.pid, getattr(signal, sig))
        code = proc.wait(STOP_S)
        assert time.monotonic() - t0 < STOP_S
    finally:
        _end(proc, [])
    err = proc.stderr.read()
    assert code == 128 + getattr(signal, sig) and list(tmp_path.iterdir()) == [], err
    assert "stopped by" in err


def test_a_signal_while_workers_fork_is_raised_after_and_ends_the_fork():
    """Inside ``signals_held`` a signal is noted, not lost in a fork hook, and raised on
    leaving; a child forked inside and signalled before it is a worker exits 128 + sig,
    silently."""
    code = ("import os, signal, sys, time\n"
            "from cml_edge.engine.stop import Stopped, signals_held, stop_on_signals\n"
            "with stop_on_signals():\n"
            "    try:\n"
            "        with signals_held():\n"
            "            pid = os.fork()\n"
            "            if pid == 0:\n"
            "                time.sleep(30)\n"
            "                os._exit(0)\n"
            "            time.sleep(0.5)\n"
            "            os.kill(pid, signal.SIGTERM)\n"
            "            os.kill(os.getpid(), signal.SIGTERM)\n"
            "            child = os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1])\n"
            "            print('inside', child)\n"
            "    except Stopped as exc:\n"
            "        print('raised', exc.signum)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=60)
    assert out.stdout.split() == ["inside", str(128 + signal.SIGTERM), "raised",
                                  str(int(signal.SIGTERM))], out
    assert out.stderr == ""


def test_a_stop_inside_an_import_is_a_stop_not_a_traceback(monkeypatch, capsys, tmp_path):
    """A SIGTERM handled while a C extension initialises surfaces as ``ImportError:
    initialization failed`` raised from the Stopped; the command still exits as stopped."""
    from cml_edge import cli
    from cml_edge.engine.stop import Stopped

    def run(args):
        try:
            raise Stopped(signal.SIGTERM)
        except Stopped as exc:
            raise ImportError("initialization failed") from exc

    parser = cli.build_parser()
    args = parser.parse_args(["train", "--out", str(tmp_path / "m.npz")])
    args.run = run
    monkeypatch.setattr(cli, "build_parser", lambda: parser)
    monkeypatch.setattr(parser, "parse_args", lambda argv: args)
    assert cli.main([]) == 128 + signal.SIGTERM
    assert not (tmp_path / "m.npz").exists()
    assert "stopped by SIGTERM" in capsys.readouterr().err


def test_an_exception_without_a_stop_behind_it_is_raised():
    from cml_edge.engine.stop import interrupt_behind

    try:
        try:
            raise ValueError("a bug")
        except ValueError as inner:
            raise ImportError("initialization failed") from inner
    except ImportError as exc:
        assert interrupt_behind(exc) is None
