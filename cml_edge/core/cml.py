"""The Cognitive Map Learner (paper 2.1): three synaptic arrays and what is read from them.

- W_q (N_s x N_i) embeds an observation: s = W_q o;
- W_v (N_s x N_a) predicts an action's effect: s_hat_{t+1} = s_t + W_v a_t;
- W_k (N_a x N_s) gives the affordance g = sigmoid(W_k s);
- planning scores each action by utility u = W_v^T (s* - s) times affordance.

Choices the paper leaves open, made here:

- Observation frame: o = (p - obs_origin) / obs_scale with the origin at the centre
  of the training arena (14.5 for 30 x 30, as Webots' arenas, the paper's simulator,
  put the origin at the centre) and obs_scale its side (30), so o lies in
  [-0.5, 0.5]^2 while training. The frame is frozen into the model; a larger
  evaluation arena simply gives |o| > 0.5. Why centred: the affordance
  sigmoid(W_k W_q o) has no bias term, so with o in [0, 1]^2 it cannot be near-uniform
  in the interior, and its distortion of u * g lengthens paths and loses goals (measured
  in docs/choices.md). Why scaled: Eq. 3's per-walk sum has gain lr * steps * E|o|^2,
  0.15 here; raw metre coordinates (|o|^2 up to 1,682) would diverge.
- Initialisation: W_q ~ N(0, 1/N_s), so |s| ~ |o| and Eq. 1's per-walk gain
  lr * steps * E|s|^2 stays ~0.15 (with W_q ~ N(0, 1) it is ~40 and W_k overshoots,
  saturating g at 0 or 1); W_k, W_v ~ N(0, 0.1^2) as in public CML ports of Stöckl
  et al. (2022). All drawn from the model seed.
- Displacement reads: s* - s and s_{t+1} - s_t are read as W_q (o* - o) and
  W_q (o_{t+1} - o_t), one read each with the difference formed before the array.
  The embedding is linear, so this is the same quantity; on a noisy or quantised
  array it avoids subtracting two large noisy reads, whose difference near the goal is
  small against their read noise.
- Utility: ``normalized`` (default) divides each u_a by the norm of W_v's column a,
  read once per planning batch, so the longer diagonal action vectors do not win
  near the goal; ``raw`` is the paper's plain inner product. Measured in docs/choices.md.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from cml_edge.backends import SynapticArray, make_array
from cml_edge.core.records import Record
from cml_edge.core.step import norms_and_gram, prepare, scores
from cml_edge.errors import InputError
from cml_edge.protocol import STREAM_INIT
from cml_edge.sizes import checked_float

UTILITIES = ("normalized", "raw")


@dataclass(frozen=True)
class CMLConfig(Record):
    """Sizes, learning rates and the choices documented in the module docstring."""

    what = "CML config"

    n_s: int = 256
    n_i: int = 2
    n_a: int = 8  # the grid's eight king moves; the robot's eight wheel-speed pairs
    lr_q: float = 0.001
    lr_k: float = 0.001
    lr_v: float = 0.001
    obs_scale: float = 30.0
    obs_origin: float = 14.5
    utility: str = "normalized"
    init_std_q: float = 0.0625
    init_std_k: float = 0.1
    init_std_v: float = 0.1

    def __post_init__(self) -> None:
        for name in ("n_s", "n_i", "n_a"):
            v = getattr(self, name)
            if isinstance(v, bool) or int(v) != v or v < 1:
                raise InputError(f"{name} {v!r} is not a positive integer")
        for name in ("lr_q", "lr_k", "lr_v", "init_std_q", "init_std_k", "init_std_v"):
            v = getattr(self, name)
            if not np.isfinite(v) or v < 0:
                raise InputError(f"{name} {v!r} is not a finite number >= 0")
        if not np.isfinite(self.obs_origin):
            raise InputError(f"obs_origin {self.obs_origin!r} is not finite")
        checked_float("obs_scale", self.obs_scale, "obs_scale")
        if self.utility not in UTILITIES:
            raise InputError(f"unknown utility {self.utility!r}; allowed: {', '.join(UTILITIES)}")

    @classmethod
    def for_arena(cls, size: int, **overrides: Any) -> CMLConfig:
        """The defaults with the observation frame of a ``size`` x ``size`` training arena."""
        return cls(**{"obs_scale": float(size), "obs_origin": (size - 1) / 2.0, **overrides})



class CML:
    """A CML whose three matrices live on synaptic arrays of one backend.

    The methods below are the readable reference path (one array call each); the
    compiled loops in :mod:`cml_edge.grid.training` and :mod:`cml_edge.grid.planning` do the
    same calls through the same kernels.
    """

    def __init__(self, config: CMLConfig, arrays: tuple[SynapticArray, ...], backend: str):
        self.config = config
        self.W_q, self.W_k, self.W_v = arrays
        self.backend = backend
        expected = ((config.n_s, config.n_i), (config.n_a, config.n_s), (config.n_s, config.n_a))
        for name, arr, shape in zip(("W_q", "W_k", "W_v"), arrays, expected):
            if arr.shape != shape:
                raise InputError(f"{name} has shape {arr.shape}, expected {shape}")

    @classmethod
    def create(cls, config: CMLConfig | None = None, backend: str = "float", seed: int = 0,
               chip: int | None = None, **backend_options: Any) -> CML:
        """A freshly initialised CML on ``backend`` (weights drawn from ``seed``).

        ``chip``: the chip seed, the seed of the arrays' device streams (None: ``seed``,
        one chip per model); see :mod:`cml_edge.grid.chips`.
        """
        config = config or CMLConfig()
        rng = np.random.default_rng([int(seed), STREAM_INIT])
        W_q = rng.normal(0.0, config.init_std_q, (config.n_s, config.n_i))
        W_k = rng.normal(0.0, config.init_std_k, (config.n_a, config.n_s))
        W_v = rng.normal(0.0, config.init_std_v, (config.n_s, config.n_a))
        device_seed = seed if chip is None else chip
        arrays = tuple(make_array(backend, W, seed=device_seed, index=i, **backend_options)
                       for i, W in enumerate((W_q, W_k, W_v)))
        return cls(config, arrays, backend)

    @property
    def arrays(self) -> tuple[SynapticArray, SynapticArray, SynapticArray]:
        return self.W_q, self.W_k, self.W_v

    # paper 2.1 -------------------------------------------------------------------
    def observe(self, pos) -> np.ndarray:
        """o = (p - obs_origin) / obs_scale (the frame of the module docstring)."""
        return (np.asarray(pos, dtype=np.float64) - self.config.obs_origin) / self.config.obs_scale

    def embed(self, o: np.ndarray) -> np.ndarray:
        """s = W_q o."""
        return self.W_q.matvec(o)

    def displacement(self, o_from: np.ndarray, o_to: np.ndarray) -> np.ndarray:
        """s(o_to) - s(o_from), read once as W_q (o_to - o_from)."""
        return self.W_q.matvec(o_to - o_from)

    def action_effect(self, a: int) -> np.ndarray:
        """W_v a for the one-hot action a (so s_hat_{t+1} = s_t + W_v a_t)."""
        return self.W_v.matvec(one_hot(a, self.config.n_a))

    def affordance(self, s: np.ndarray) -> np.ndarray:
        """g = sigmoid(W_k s)."""
        return self.W_k.sigmoid(self.W_k.matvec(s))

    # paper 2.4.3 -----------------------------------------------------------------
    def parameter_count(self) -> int:
        """(N_i + 2 N_a) N_s: the entries of W_q, W_k and W_v (4,608 for the paper's sizes)."""
        c = self.config
        return (c.n_i + 2 * c.n_a) * c.n_s

    def inference_flops(self) -> int:
        """(2 N_i + 4 N_a + 1) N_s - N_a FLOPs per planning step (9,464), the paper's count."""
        c = self.config
        return (2 * c.n_i + 4 * c.n_a + 1) * c.n_s - c.n_a

    # hardware view ---------------------------------------------------------------
    def counters(self) -> dict[str, int]:
        """The three arrays' counters, summed by name."""
        total: dict[str, int] = {}
        for arr in self.arrays:
            for k, v in arr.counters.items():
                total[k] = total.get(k, 0) + v
        return total

    def reset_counters(self) -> None:
        for arr in self.arrays:
            arr.reset_counters()

    def weights(self) -> dict[str, np.ndarray]:
        """The effective float64 weights of the three matrices."""
        return {"W_q": self.W_q.to_float(), "W_k": self.W_k.to_float(),
                "W_v": self.W_v.to_float()}


def one_hot(a: int, n: int) -> np.ndarray:
    v = np.zeros(n)
    v[a] = 1.0
    return v


class ReferenceScorer:
    """Utility x affordance through the CML's Python methods: the scorer of the reference
    path (:func:`cml_edge.core.step.scores`), held bit-identical to the compiled
    :class:`~cml_edge.core.step.SeamScorer`."""

    def __init__(self, cml: CML) -> None:
        n_a = cml.config.n_a
        self.cml = cml
        self.norms = np.ones(n_a)
        self.gram = np.zeros((n_a, n_a))

    def prepare(self, normalize: bool, gram: bool) -> None:
        if not (normalize or gram):
            self.norms[:] = 1.0
            return
        cols = np.array([self.cml.action_effect(a) for a in range(self.cml.config.n_a)])
        norms_and_gram(cols, normalize, gram, self.norms, self.gram)

    def scores(self, o: np.ndarray, dgo: np.ndarray, u: np.ndarray, score: np.ndarray) -> None:
        cml = self.cml
        u[:] = cml.W_v.rmatvec(cml.W_q.matvec(dgo))  # W_v^T (s* - s), s* - s read once
        score[:] = u / self.norms * cml.affordance(cml.embed(o))


prepare.register(ReferenceScorer, ReferenceScorer.prepare)
scores.register(ReferenceScorer, ReferenceScorer.scores)
