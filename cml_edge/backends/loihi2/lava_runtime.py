"""Run Intel Lava 0.10.0's CPU simulator on a file of work: the side of ``cml-edge lava verify``
that runs in the Lava virtual environment (Python 3.10; ``scripts/lava_env.sh`` builds it).

Run as ``python -I lava_runtime.py IN.npz OUT.npz`` (``-I``: the script's folder, which holds
this package's own ``lava.py``, stays off ``sys.path``). It imports Lava and NumPy only, not
``cml_edge``: :mod:`cml_edge.backends.loihi2.conformance` writes IN and reads OUT.

IN holds, for each read ``R`` named in ``reads``: ``R/weights`` (out, in), ``R/payloads``
(steps, in), ``R/params`` [weight_exp, num_weight_bits, num_message_bits] and
``R/sign_mode`` (a ``SignMode`` name). A network per read runs under
``Loihi2SimCfg(select_tag="fixed_pt")``: a ``RingBuffer`` source sends the payloads as graded
spikes to a ``Dense``, whose ``a_out`` goes to a ``RingBuffer`` sink and to a ``LIF``
(du 4095, dv 4095: the current is the step's input) whose ``u`` a ``Monitor`` records.
OUT: ``R/a_out`` and ``R/u`` (steps, out), row t the read of payload row t (the Dense
sends a step late).

For each learning run ``L`` named in ``learn``: ``L/weights`` (out, in), ``L/sign_mode``,
``L/params`` [weight_exp, num_weight_bits], ``L/X`` (epochs, in) signed pre traces,
``L/Y`` (epochs, out) signed post traces, ``L/rule`` (epochs, 3) the literal
[m, k, c] of the rule ``m * 2^(k - 7) * x0 * (x1 - c) * y1`` (``x1`` where c is 0),
``L/tau`` the traces' decay time constant (x1's and y1's). A ``LearningDense`` with a
``Loihi3FLearningRule`` (t_epoch 1, graded spikes ``OVERWRITE``) runs one step per epoch: the
pre neurons with X != 0 send 2 (X + c) as their payloads (the engine's x1 is
round(payload / 2)), the others stay silent; a source standing in for the post neurons'
third factor sends Y to ``s_in_y1``. Consecutive epochs with one rule share a process; a
new rule starts a new process from the weights reached.
OUT: ``L/weights`` (epochs, out, in) after each epoch, ``L/x1`` (the pre traces the rule
read, after Lava's one step of trace decay), ``L/y1`` (the post traces as written: Lava's
3-factor model keeps their decayed values in the epoch's history only) and ``L/draw``
(the index of the epoch's write-back draw in its process's ``ConnVarRandom`` stream).
"""

from __future__ import annotations

import sys

import numpy as np
from lava.magma.core.learning.learning_rule import Loihi3FLearningRule
from lava.magma.core.run_conditions import RunSteps
from lava.magma.core.run_configs import Loihi2SimCfg
from lava.proc.dense.process import Dense, GradedSpikeCfg, LearningDense
from lava.proc.io.sink import RingBuffer as Sink
from lava.proc.io.source import RingBuffer as Source
from lava.proc.lif.process import LIF
from lava.proc.monitor.process import Monitor
from lava.utils.weightutils import SignMode

RUN_CFG = Loihi2SimCfg(select_tag="fixed_pt")


def run_read(data: dict, name: str) -> dict[str, np.ndarray]:
    """The reads of ``name`` (module docstring): a network of its own (Lava runs the
    processes connected to the one it is asked to run)."""
    W = data[f"{name}/weights"].astype(np.int32)
    exp, nb, msg = (int(v) for v in data[f"{name}/params"])
    rows = data[f"{name}/payloads"].shape[0]
    pay = np.zeros((W.shape[1], rows + 1), np.int32)
    pay[:, :rows] = data[f"{name}/payloads"].T
    src = Source(data=pay)
    dense = Dense(weights=W, weight_exp=exp, num_weight_bits=nb,
                  sign_mode=SignMode[str(data[f"{name}/sign_mode"])], num_message_bits=msg)
    lif = LIF(shape=(W.shape[0],), du=4095, dv=4095, vth=(1 << 23) - 1, bias_mant=0)
    sink = Sink(shape=(W.shape[0],), buffer=rows + 1)
    src.s_out.connect(dense.s_in)
    dense.a_out.connect(lif.a_in)
    dense.a_out.connect(sink.a_in)
    mon = Monitor()
    mon.probe(lif.u, rows + 1)
    dense.run(condition=RunSteps(rows + 1), run_cfg=RUN_CFG)
    a_out = sink.data.get().T[1:].astype(np.int64)
    u = np.asarray(mon.get_data()[lif.name]["u"])[1:].astype(np.int64)
    dense.stop()
    return {f"{name}/a_out": a_out, f"{name}/u": u}


def run_learning(data: dict, name: str) -> dict[str, np.ndarray]:
    """The epochs of learning run ``name`` (module docstring)."""
    W = data[f"{name}/weights"].astype(np.int32)
    mode = SignMode[str(data[f"{name}/sign_mode"])]
    exp, nb = (int(v) for v in data[f"{name}/params"])
    X, Y, rule = data[f"{name}/X"], data[f"{name}/Y"], data[f"{name}/rule"]
    tau = int(data[f"{name}/tau"])
    weights, x1, y1, draw = [], [], [], []
    t = 0
    while t < len(rule):
        m, k, c = (int(v) for v in rule[t])
        end = t
        while end < len(rule) and tuple(int(v) for v in rule[end]) == (m, k, c):
            end += 1
        factor = f"(x1 - {c})" if c else "x1"
        lr = Loihi3FLearningRule(dw=f"{m} * 2^{k - 7} * x0 * {factor} * y1", x1_tau=tau,
                                 t_epoch=1, rng_seed=0)
        lr.y1_tau = tau  # Loihi3FLearningRule's own is 65535
        spikes = X[t:end].T
        pre = Source(data=np.where(spikes != 0, 2 * (spikes + c), 0).astype(np.int32))
        post = Source(data=Y[t:end].T.astype(np.int32))
        conn = LearningDense(weights=W, weight_exp=exp, num_weight_bits=nb, sign_mode=mode,
                             num_message_bits=24, learning_rule=lr,
                             graded_spike_cfg=GradedSpikeCfg.OVERWRITE)
        pre.s_out.connect(conn.s_in)
        post.s_out.connect(conn.s_in_y1)
        for i in range(end - t):
            conn.run(condition=RunSteps(1), run_cfg=RUN_CFG)
            weights.append(conn.weights.get().astype(np.int64))
            x1.append(conn.x1.get().astype(np.int64))
            y1.append(conn.y1.get().astype(np.int64))
            draw.append(i + 1)
        W = weights[-1].astype(np.int32)
        conn.stop()
        t = end
    return {f"{name}/weights": np.array(weights), f"{name}/x1": np.array(x1),
            f"{name}/y1": np.array(y1), f"{name}/draw": np.array(draw)}


def main(path_in: str, path_out: str) -> None:
    with np.load(path_in, allow_pickle=False) as f:
        data = {k: f[k] for k in f.files}
    out: dict[str, np.ndarray] = {}
    for name in data.get("reads", []):
        out.update(run_read(data, str(name)))
    for name in data.get("learn", []):
        out.update(run_learning(data, str(name)))
    np.savez(path_out, **out)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
