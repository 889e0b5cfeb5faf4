"""The parts of the DQN baseline that touch torch, stable-baselines3 and gymnasium.

Imported only by :mod:`cml_edge.baselines.dqn` when a command runs (never at package
load). It takes its settings from :mod:`cml_edge.baselines.settings` and never imports
:mod:`cml_edge.baselines.dqn`, so the two do not import each other. torch runs on one
thread: two threads on the 2-core machine collapse under contention.
"""

from __future__ import annotations

import io
import os
import time
from pathlib import Path
from typing import Any

import gymnasium
import numpy as np
import stable_baselines3
import torch
from stable_baselines3 import DQN
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.monitor import Monitor

from cml_edge.baselines.settings import HYPERPARAMS, NET_ARCH, DQNRun
from cml_edge.grid.arena import GridArena
from cml_edge.grid.env import GridNavEnv, apply_moves, scale_positions
from cml_edge.grid.metrics import Pairs
from cml_edge.io.files import atomic_write

torch.set_num_threads(1)


def versions() -> dict[str, str]:
    return {"torch": torch.__version__, "stable_baselines3": stable_baselines3.__version__,
            "gymnasium": gymnasium.__version__, "torch_threads": torch.get_num_threads()}


def make_env(run: DQNRun, goal: np.ndarray | None) -> GridNavEnv:
    """The training environment of one seed: fixed ``goal``, or goal-conditioned."""
    return GridNavEnv(size=run.arena, goal=None if goal is None else tuple(goal),
                      goal_conditioned=run.goal_conditioned, reward=run.reward)


def make_model(env, seed: int) -> DQN:
    """SB3's (vanilla) DQN with the original stable-baselines hyperparameters (HYPERPARAMS)
    and the paper's network: inputs -> 64 -> 64 -> 8, ReLU."""
    return DQN("MlpPolicy", env, seed=seed, device="cpu", verbose=0,
               policy_kwargs={"net_arch": list(NET_ARCH), "activation_fn": torch.nn.ReLU},
               **HYPERPARAMS)


def q_network_layers(model: DQN) -> list[int]:
    """Layer widths read off the online Q network: [in, 64, 64, 8]."""
    linears = [m for m in model.q_net.q_net if isinstance(m, torch.nn.Linear)]
    return [linears[0].in_features] + [m.out_features for m in linears]


def q_network_parameters(model: DQN) -> int:
    """Parameters of the online Q network (the target network is a copy, not counted)."""
    return int(sum(p.numel() for p in model.q_net.parameters()))


def rollout(model: DQN, arena: GridArena, pairs: Pairs, goal_conditioned: bool,
            max_steps: int = 100) -> tuple[np.ndarray, np.ndarray]:
    """Greedy episodes (``predict(deterministic=True)``) from every start to its goal, all
    trials batched; same dynamics as the environment (:func:`apply_moves`). Stops a trial
    on its goal. Returns final positions and actions taken."""
    pos = pairs.starts.astype(np.int64).copy()
    goals = pairs.goals.astype(np.int64)
    steps = np.zeros(len(pos), np.int64)
    active = ~(pos == goals).all(axis=1)
    free = arena.free
    for _ in range(max_steps):
        idx = np.flatnonzero(active)
        if len(idx) == 0:
            break
        cells = np.concatenate([pos[idx], goals[idx]], axis=1) if goal_conditioned else pos[idx]
        actions, _ = model.predict(scale_positions(cells, arena.size), deterministic=True)
        pos[idx] = apply_moves(free, pos[idx], actions)
        steps[idx] += 1
        active[idx[(pos[idx] == goals[idx]).all(axis=1)]] = False
    return pos, steps


class CurveCallback(BaseCallback):
    """Figure 4A data: every ``eval_every`` steps, the mean return of the episodes that
    ended since the last point, and the greedy policy's e_pos on the evaluation pairs.
    The time spent evaluating is excluded from the training time it records."""

    def __init__(self, evaluate, eval_every: int) -> None:
        super().__init__()
        self.evaluate = evaluate
        self.eval_every = eval_every
        self.points: list[dict[str, Any]] = []
        self.returns: list[float] = []
        self.all_returns: list[float] = []
        self.eval_wall = 0.0
        self.eval_cpu = 0.0

    def _on_training_start(self) -> None:
        self.t0 = time.perf_counter()
        self.c0 = time.process_time()
        self._point()

    def _on_step(self) -> bool:
        for info in self.locals.get("infos", []):
            if "episode" in info:
                self.returns.append(float(info["episode"]["r"]))
        if self.num_timesteps % self.eval_every == 0:
            self._point()
        return True

    def _point(self) -> None:
        w0, c0 = time.perf_counter(), time.process_time()
        train_wall = w0 - self.t0 - self.eval_wall
        train_cpu = c0 - self.c0 - self.eval_cpu
        summary = self.evaluate(self.model)
        self.points.append({
            "step": int(self.num_timesteps),
            "train_wall_s": train_wall, "train_cpu_s": train_cpu,
            "episodes": len(self.returns),
            "return_mean": float(np.mean(self.returns)) if self.returns else None,
            "e_pos_mean": summary["e_pos_mean"], "success_rate": summary["success_rate"],
        })
        self.all_returns.extend(self.returns)
        self.returns = []
        self.eval_wall += time.perf_counter() - w0
        self.eval_cpu += time.process_time() - c0


def save_model(model: DQN, path: str | Path) -> None:
    """Save an SB3 model zip atomically."""
    buf = io.BytesIO()
    model.save(buf)
    atomic_write(path, lambda f: f.write(buf.getvalue()))


def load_model(path: str | Path) -> DQN:
    return DQN.load(str(path), device="cpu")


def train_seed(run: DQNRun, seed: int, goal: np.ndarray | None, arena: GridArena, pairs: Pairs,
               summarize_fn, model_path: str | Path | None) -> dict[str, Any]:
    """Train one seed for ``run.steps`` steps; returns its JSON-ready record."""
    env = Monitor(make_env(run, goal))
    model = make_model(env, seed)

    def evaluate(m: DQN) -> dict[str, Any]:
        final, steps = rollout(m, arena, pairs, run.goal_conditioned)
        return summarize_fn(final, steps, pairs)

    cb = CurveCallback(evaluate, run.eval_every)
    load0 = os.getloadavg()
    w0, c0 = time.perf_counter(), time.process_time()
    model.learn(total_timesteps=run.steps, callback=cb, progress_bar=False)
    if cb.points[-1]["step"] != model.num_timesteps:
        cb._point()
    wall = time.perf_counter() - w0 - cb.eval_wall
    cpu = time.process_time() - c0 - cb.eval_cpu
    final, steps = rollout(model, arena, pairs, run.goal_conditioned)
    if model_path is not None:
        save_model(model, model_path)
    return {
        "seed": int(seed),
        "goal": None if goal is None else [int(g) for g in goal],
        "steps": int(model.num_timesteps),
        "train_wall_s": wall, "train_cpu_s": cpu,
        "loadavg_start": list(load0), "loadavg_end": list(os.getloadavg()),
        "episodes": len(cb.all_returns) + len(cb.returns),
        "curve": cb.points,
        "final": final.tolist(), "final_steps": steps.tolist(),
        "evaluation": summarize_fn(final, steps, pairs),
        "parameters": q_network_parameters(model),
        "layers": q_network_layers(model),
        "model_file": None if model_path is None else str(model_path),
    }
