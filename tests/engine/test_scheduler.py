"""Dask scheduler addresses checked before any work, and a scheduler lost mid-run: one line
naming what finished and how to resume, and a rerun that resumes from the kept tasks."""

import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from cml_edge.engine.sweep import SchedulerLostError, Task, check_scheduler, run_sweep, task_path
from cml_edge.errors import InputError


def slow(i: int) -> dict:
    """A task that takes a moment (the scheduler is lost while some still run)."""
    time.sleep(0.3)
    return {"i": i}


@pytest.mark.parametrize("address", ["tcp://127.0.0.1:8786", "localhost:8786",
                                     "tls://sched.example.org:8786", "[::1]:8786",
                                     "ws://h:1", "inproc://192.168.1.2/123/4"])
def test_scheduler_addresses(address):
    assert check_scheduler(address) == address


@pytest.mark.parametrize("address", ["nonsense", "", "tcp://", "host:", "host:0",
                                     "host:65536", "ftp://host:21", "tcp://host:port",
                                     "tcp://-h:1", "h:1:2", " h:1"])
def test_bad_scheduler_addresses(address):
    with pytest.raises(InputError, match="not a Dask scheduler address"):
        check_scheduler(address)


@pytest.mark.parametrize("argv", [["scenario", "paper"], ["sweep", "convergence"],
                                  ["breakpoint", "--knob", "read_noise", "--scenario", "paper",
                                   "--backend", "crossbar"],
                                  ["emulate", "--backend", "crossbar", "--chips", "2"]])
def test_a_bad_address_is_refused_before_any_work(argv, cli, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    t0 = time.perf_counter()
    code, out, err = cli(*argv, "--scheduler", "nonsense", "--out" if argv[0] != "emulate"
                         else "--chips-out", tmp_path / "o")
    assert code == 2 and err.count("\n") == 1 and "--scheduler 'nonsense'" in err, err
    assert time.perf_counter() - t0 < 10 and list(tmp_path.iterdir()) == []


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def _start(*argv: str) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(Path(__file__).parent), os.getcwd(), os.environ.get("PYTHONPATH", "")])}
    return subprocess.Popen([sys.executable, "-m", *argv], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)


def test_a_lost_scheduler_ends_with_one_line_and_the_run_resumes(tmp_path):
    pytest.importorskip("distributed")
    address = f"tcp://127.0.0.1:{_free_port()}"
    scheduler = _start("distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port",
                       address.rsplit(":", 1)[1], "--no-dashboard")
    worker = _start("distributed.cli.dask_worker", address, "--nthreads", "1",
                    "--no-dashboard")
    tasks = [Task(f"t{i}", "test_scheduler:slow", {"i": i}) for i in range(8)]

    def progress(done, total):
        if done == 1:  # one task finished: the scheduler dies
            scheduler.kill()

    try:
        t0 = time.perf_counter()
        with pytest.raises(SchedulerLostError) as info:
            run_sweep(tasks, tmp_path, scheduler=address, progress=progress)
        took = time.perf_counter() - t0
    finally:
        for proc in (scheduler, worker):
            proc.kill()
            proc.wait()
    message = str(info.value)
    assert "\n" not in message and "run the same command again to resume" in message
    kept = [t for t in tasks if task_path(tmp_path, t.key).exists()]
    assert f"with {len(kept)} of 8 tasks finished" in message and 0 < len(kept) < 8
    assert str(tmp_path / "tasks") in message and took < 60
    # the rerun (here in-process) computes only what was not kept
    ran = []
    done = run_sweep(tasks, tmp_path, workers=1, progress=lambda d, t: ran.append(d))
    assert ran[0] == len(kept) and [done[t.key]["i"] for t in tasks] == list(range(8))


def test_a_lost_scheduler_without_a_folder_says_how_to_keep_tasks(tmp_path):
    err = SchedulerLostError("tcp://h:1", "CommClosedError", 2, 5, None)
    assert "give --out to make a run resumable" in str(err) and "2 of 5" in str(err)


def test_the_command_line_ends_a_lost_run_with_one_line(cli, tmp_path, monkeypatch):
    def lost(*args, **kwargs):
        raise SchedulerLostError("tcp://h:1", "scheduler-connection-lost", 3, 10,
                                 tmp_path / "tasks")

    monkeypatch.setattr("cml_edge.cli.scenario.run_scenario", lost)
    code, out, err = cli("scenario", "paper", "--scheduler", "tcp://h:1", "--out", tmp_path)
    assert code == 1 and out == "" and err.count("\n") == 1
    assert err.startswith("cml-edge: error: lost the Dask scheduler 'tcp://h:1' "
                          "(scheduler-connection-lost) with 3 of 10 tasks finished; they are "
                          "kept in"), err
