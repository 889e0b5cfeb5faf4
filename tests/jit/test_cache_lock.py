"""Processes that share the kernel cache keep every entry of its index
(cml_edge.jit.cache_lock): two that save two signatures of one function at once keep both;
two that need the same signature at once compile it once."""

import json
import subprocess
import sys
import textwrap

import pytest

_SCRIPT = textwrap.dedent("""
    import json, multiprocessing as mp, time
    from numba.core import caching, event
    import cml_edge.jit
    import slowmod

    def counted():  # the names of the functions this process compiles from now on
        names = []
        class Count(event.Listener):
            def on_start(self, ev):
                names.append(ev.data["dispatcher"].py_func.__name__)
            def on_end(self, ev):
                pass
        event.register("numba:compile", Count())
        return names

    def child(barrier, arg, out):
        compiled = counted()
        save_index = caching.IndexDataCacheFile._save_index
        def slow(self, overloads):  # widen the index's read-change-write window
            time.sleep(0.5)
            save_index(self, overloads)
        caching.IndexDataCacheFile._save_index = slow
        barrier.wait()
        slowmod.f(arg)
        out.put(compiled.count("f"))

    if __name__ == "__main__":
        ctx = mp.get_context("fork")
        barrier, out = ctx.Barrier(2), ctx.Queue()
        args = ARGS
        procs = [ctx.Process(target=child, args=(barrier, a, out)) for a in args]
        for p in procs:
            p.start()
        results = [out.get(timeout=120) for _ in procs]
        for p in procs:
            p.join()
        # a third process: what the index holds now
        reloads = counted()
        for a in args:
            slowmod.f(a)
        print(json.dumps({"compiled": results, "recompiled": reloads.count("f")}))
""")


def _slow_module(n: int = 150) -> str:
    body = "\n".join(f"    x = x * 0.999 + {i}.0 / (x + {i + 1}.0)" for i in range(n))
    return f"from numba import njit\n\n@njit(cache=True)\ndef f(x):\n{body}\n    return x\n"


def _run(tmp_path, args: str = "(1.0, 1)") -> dict:
    (tmp_path / "slowmod.py").write_text(_slow_module())
    (tmp_path / "run.py").write_text(_SCRIPT.replace("ARGS", args))
    env = {"NUMBA_CACHE_DIR": str(tmp_path / "cache"), "PYTHONPATH": str(tmp_path),
           "PATH": "/usr/bin:/bin"}
    done = subprocess.run([sys.executable, str(tmp_path / "run.py")], env=env,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.splitlines()[-1])


@pytest.mark.slow
def test_two_signatures_saved_at_once_both_stay_in_the_index(tmp_path):
    out = _run(tmp_path)
    assert out["compiled"] == [1, 1]  # two signatures: each compiled once
    assert out["recompiled"] == 0  # and both loaded from the cache afterwards


@pytest.mark.slow
def test_one_signature_needed_at_once_is_compiled_once(tmp_path):
    out = _run(tmp_path, "(1.0, 2.0)")  # one signature in both processes
    assert sorted(out["compiled"]) == [0, 1]  # the second waited, then loaded it
    assert out["recompiled"] == 0
