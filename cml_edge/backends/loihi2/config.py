"""Configuration of the ``loihi2`` array, as data: :class:`Loihi2Config`.

Every option is a parameter Lava's ``Dense`` / ``LearningDense`` and ``LoihiLearningRule``
take (``num_message_bits``, ``num_weight_bits``, ``weight_exp``, ``sign_mode``,
``t_epoch``) or a choice this emulation makes where Lava is silent (the stochastic
rounding draws, the payload scale, strict mode), each documented under its field. The
ranges are the chip's as the project fixes them: ``num_weight_bits`` 1..8
(Lava: ``W_WEIGHTS_U`` = 8), ``weight_exp`` -8..7 (Lava's Python checks no range;
nengo-loihi's Loihi 1 synapse scale 2^(6 + weight_exp) with this range), and
``num_message_bits`` 1..24 (Lava's graded networks and adapters use 24; no documented hard
limit exists). Anything outside is refused with one line naming it and the range.

The kernels read :class:`Loihi2Params`: the config's numeric fields and what an array
derives from its matrix (:func:`loihi2_params`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from cml_edge.backends.device import CostModel, Knob
from cml_edge.backends.fields import check_types, option, resolve
from cml_edge.backends.loihi2.lava import SIGN_MODES, weight_limits
from cml_edge.backends.params import build_record, kernel_record
from cml_edge.backends.quant import check_int
from cml_edge.errors import InputError

MIN_WEIGHT_EXP, MAX_WEIGHT_EXP = -8, 7
MAX_MESSAGE_BITS = 24
MAX_T_EPOCH = 63  # Lava: W_EPOCH_TIME = 6 (tx, ty are 6-bit)
DRAWS = ("shared", "independent")
PAYLOAD_SCALES = ("safe", "full")
TERMS = ("engine", "exact")
TRACES = ("nearest", "stochastic")
MAPPINGS = ("learned", "initial")
LEARNED_GAIN = (0, 0, 3)
"""The ``learned`` mapping's scale gain per matrix [W_q, W_k, W_v], in powers of two over
the scale the initial weights set. W_q and W_k keep their range while learning (float64
twin, paper protocol, 30 x 30 arena: max |W_q| 0.17-0.24 and |W_k| 0.34-0.39 after
training, as at initialisation); W_v does not: Eq. 2 drives W_v a to the state
displacement W_q (o' - o) of one move, at most max_i ||W_q[i, :]||_1 / obs_scale (0.012
for the default config), and the trained W_v reaches 0.009-0.010 against its initial
0.34-0.38 (2^-5). Programmed at the initial weights' scale, the trained W_v uses about
+-10 of its +-256 levels and each step's update is a fraction of the accumulator's unit.
The gain 2^3 puts the trained W_v at about +-80 of them (a quarter of the 8-bit standard
range, room for the larger displacements early in training); the initial weights beyond
that range (|w| > 0.062 in float: about half of W_v's) are clipped there and counted
(``program_clips``), and learning decays them. Measured on 10 seeds, step schedule:
gain 2 gave decision agreement 0.830, gain 3 0.860 (int8: 0.835)."""
U_BITS = 24  # the neuron's state u (PyLifModelBitAcc: 24 bits)
ACT_SHIFT = 6  # PyLifModelBitAcc: a_in << 6 into u
SCALE_LIMIT = 1000  # |scale_exp| beyond this is no float64 scale


@dataclass(frozen=True)
class Loihi2Config:
    """What a Loihi 2 ``Dense`` / ``LearningDense`` and its learning rule are given."""

    num_message_bits: int = option(
        24, flag="--message-bits", metavar="N",
        help="graded-spike payload bits 1..24 (loihi2; default 24)",
        lo=1, hi=MAX_MESSAGE_BITS, why="Lava's graded spikes carry up to 24 bits")
    """Bits of a graded spike's integer payload, 1..24 (Lava ``num_message_bits``).
    Payloads are signed two's complement (Lava's ``OutputVec`` sign-extends 24-bit
    payloads), used symmetrically: |payload| <= 2^(N-1) - 1, so 1 bit carries only zero.
    Default 24, what Lava's graded networks use."""
    num_weight_bits: int | None = option(
        None, flag="--weight-bits", metavar="N", kernel=False,
        help="weight bits 1..8 (loihi2; default: what optimize_weight_bits gives)",
        lo=1, hi=8, why="Lava: W_WEIGHTS_U = 8")
    """Weight bits, 1..8 (Lava ``num_weight_bits``): the programmed weights are
    ``truncate_weights(W, sign_mode, num_weight_bits)``. Default None: what
    ``optimize_weight_bits`` gives for the matrix (8 for generic weights; for an
    all-zero matrix Lava gives 0, kept here as 1: every width holds zeros)."""
    weight_exp: int | tuple[int, ...] | None = option(
        None, flag="--weight-exp", per_matrix="each", noun="exponents",
        help="weight exponent -8..7, one or three (W_q W_k W_v) (loihi2: default "
             "optimize_weight_bits')",
        lo=MIN_WEIGHT_EXP, hi=MAX_WEIGHT_EXP, why="nengo-loihi's synapse scale 2^(6 + weight_exp)")
    """The weight exponent, -8..7 (Lava ``weight_exp``): a read's sum is shifted by it
    (``Dense``: right by -weight_exp, floor) before the neuron scales it by 2^6, so the
    weights count 2^(6 + weight_exp) in the neuron's 24-bit input. One value or one per
    matrix [W_q, W_k, W_v]. Default None: what ``optimize_weight_bits`` gives (-1 for a
    generic mixed matrix). Fixing it keeps the integers and moves the float scale with it
    (the read's unit)."""
    scale_exp: int | tuple[int, ...] | None = option(
        None, per_matrix="each", noun="exponents", kernel=False,
        lo=-SCALE_LIMIT, hi=SCALE_LIMIT, why="2^+-1000 is still a float64 scale")
    """The float scale: a weight w stands for w 2^(weight_exp - scale_exp). Default None:
    the largest power of two that puts rint(W 2^S) in Lava's standard 8-bit range
    (``lava.float_scale``), then scale_exp = S + weight_exp - (``optimize_weight_bits``'
    exponent). Given (what a saved array records), the weights are rint(W 2^(scale_exp -
    weight_exp)) (weight_exp 0 if not given), clipped to the 9-bit range (counted) and
    truncated to num_weight_bits (8 if not given)."""
    sign_mode: str = option("mixed", flag="--sign-mode", metavar="MODE", choices=SIGN_MODES,
                            help="weight sign mode: mixed, excitatory, inhibitory (loihi2; "
                                 "default mixed)")
    """Lava ``SignMode``: ``mixed`` (code 1; weights in [-256, 255], the LSB dropped at
    programming), ``excitatory`` (2; [0, 255]) or ``inhibitory`` (3; [-255, 0]). The CML's
    matrices are mixed; the other modes clip the weights of the wrong sign to zero
    (counted), as Lava's ``clip_weights`` does. Default mixed."""
    t_epoch: int = option(1, flag="--t-epoch", metavar="T",
                          help="learning epoch in in-place updates, 1..63 (loihi2; default 1)",
                          lo=1, hi=MAX_T_EPOCH, why="Lava: W_EPOCH_TIME = 6 bits")
    """The learning epoch, 1..63 time steps (Lava ``LoihiLearningRule(t_epoch=...)``;
    6-bit on the chip): with the per-step schedule (updates not deferred) the weights are
    written back every ``t_epoch`` updates; 1 = every step. The per-walk schedule is one
    epoch per walk, whatever ``t_epoch`` says: its ``commit`` ends the epoch (900 steps,
    beyond the chip's 6-bit epoch time: the host would have to end it). Default 1."""
    draws: str = option("shared", flag="--draws", metavar="MODE", choices=DRAWS,
                        help="stochastic-rounding draws: shared (one per epoch, as Lava) or "
                             "independent (one per synapse) (loihi2; default shared)")
    """The uniform draws of the write-back's stochastic rounding: ``shared``, one per
    epoch for every synapse of the array, as Lava's learning engine model draws it
    (``ConnVarRandom``), or ``independent``, one per synapse and epoch (what a future chip
    could do). Default shared."""
    payload_scale: str = option("safe", choices=PAYLOAD_SCALES)
    """How an input vector becomes payloads (its power-of-two scale; Lava leaves this to
    the network): ``safe``, the finest scale at which every payload fits
    ``num_message_bits`` and the read cannot overflow the neuron's 24-bit input for any
    weights the 9-bit range holds (L1 norm of the payloads x 256 x 2^(6 + weight_exp)
    < 2^23), or ``full``, the finest at which the payloads fit, so that a read may overflow
    the 24-bit input (it wraps as Lava's ``PyLifModelBitAcc`` wraps u, counted). Default
    safe."""
    terms: str = option("engine", choices=TERMS)
    """How an update's product terms are formed: ``engine``, as Lava's learning engine forms
    them (7-bit traces, the 4-bit rate mantissa, the product shifted right by 3 with a
    floor, the rule's exponent at least -7), or ``exact``, NOT the chip: each term
    lr post_i pre_j computed in float64 and stochastically rounded to the accumulator's
    7 fraction bits (one draw per term), the rest as the chip. ``exact`` measures what the
    engine's term formation costs the CML. Default engine."""
    traces: str = option("nearest", choices=TRACES)
    """How an update's two traces are formed from post and pre (``terms`` ``engine``;
    with ``exact`` no trace is formed and this has no effect):

    - ``nearest``: each trace rounded to nearest (ties to even) at its vector's finest
      scale, 7 bits (6 and a sign for a signed pre vector, which travels offset by 64:
      :mod:`~cml_edge.backends.loihi2.kernels`, step 1); where the rule's exponent would
      be negative, rounded to nearest at a coarser scale instead
      (:func:`~cml_edge.backends.loihi2.kernels.coarsen`).
      A post trace is what a programmable neuron emitting its signed error as a graded
      spike (the 3-factor rule's y1, ``s_in_y1``) gives with a rounding shift; a pre
      trace the pre neuron's graded spike (Lava's x1, round(payload / 2)). Values below
      half a unit round to 0, and the engine's floored ``>> 3`` of the product floors
      negative terms away from zero: the engine's bias.
    - ``stochastic``: the same scales, but every trace is rounded stochastically,
      up with probability its fraction (one uniform draw from the array's counter-based
      stream per entry with a fraction, post entries first, then pre, counted in
      ``rng_draws``), and the pre trace keeps 3 - t low bits zero, t the trailing zero
      bits of the rule's mantissa m (m = 4, the default rates' mantissa: one bit; the
      pre trace holds 7 - (3 - t) bits, one less when signed): then 8 divides m X Y and
      the engine's ``>> 3`` is exact, so every term is an unbiased estimate of lr post
      pre (its draws independent of each other; the engine's one-step decay of the
      traces, a unit in about 65535 / |trace| epochs, aside). On the chip this is the
      sending neurons' work: a programmable neuron forming its graded spike with a
      dithered rounding (a
      pseudo-random number added below the payload's LSB before the shift that forms
      it), the pre neurons sending their payloads with those low bits cleared. Lava
      models no such neuron: its bit-accurate LIF has no random source, and the
      learning engine's ``TraceRandom`` is one draw per time step shared by every
      trace, for trace decay and impulse addition, not a dither per neuron. That
      dither is neuron microcode Lava does not model; here its draws come from the
      array's stream. The engine's rule, accumulator and write-back are unchanged, so
      Lava runs these traces as it runs the others (``cml-edge lava verify``).

    Default nearest."""
    mapping: str = option("learned", choices=MAPPINGS, kernel=False)
    """How the float matrices map to the chip's integers: ``learned``, each matrix's scale
    chosen for the range it holds after learning (:data:`LEARNED_GAIN`: W_v 2^3 finer than
    its initial weights' scale, their excess clipped and counted), or ``initial``, every
    scale set by the initial weights (the earlier mapping, kept as the documented finding:
    its trained W_v is too coarse for the engine's terms). Default learned."""
    strict: bool = option(False, flag="--strict-saturation",
                          help="raise on any saturation instead of clipping and counting")
    """Raise on any overflow (a wrapped neuron input, a saturated learning accumulator or
    product, a clipped weight) instead of handling it as the chip does and counting it.
    The learned mapping's clip of the initial weights past the range a matrix holds after
    learning is the mapping's choice, not an overflow: counted (``program_clips``), never
    refused. Default False."""

    def __post_init__(self) -> None:
        check_types(self, "loihi2 ")
        object.__setattr__(self, "num_message_bits", check_int(
            self.num_message_bits, "num_message_bits", 1, MAX_MESSAGE_BITS))
        if self.num_weight_bits is not None:
            object.__setattr__(self, "num_weight_bits", check_int(
                self.num_weight_bits, "num_weight_bits", 1, 8))
        object.__setattr__(self, "t_epoch", check_int(self.t_epoch, "t_epoch", 1, MAX_T_EPOCH))
        object.__setattr__(self, "weight_exp", _per_matrix(self.weight_exp, "weight_exp",
                                                           MIN_WEIGHT_EXP, MAX_WEIGHT_EXP))
        object.__setattr__(self, "scale_exp", _per_matrix(self.scale_exp, "scale_exp",
                                                          -SCALE_LIMIT, SCALE_LIMIT))
        object.__setattr__(self, "strict", bool(self.strict))


def _per_matrix(value: Any, name: str, lo: int, hi: int) -> int | tuple[int, ...] | None:
    if value is None:
        return None
    if isinstance(value, (list, tuple)):
        if len(value) != 3:
            raise InputError(f"{name} {list(value)!r}: give one value or three (W_q, W_k, W_v)")
        return tuple(check_int(v, name, lo, hi) for v in value)
    return check_int(value, name, lo, hi)


PRESETS: dict[str, dict[str, Any]] = {}
"""No presets: ``loihi2`` is the config's defaults, every field settable."""


def make_config(**options: Any) -> Loihi2Config:
    """The config of ``options`` (field values)."""
    return resolve(Loihi2Config, PRESETS, options, "loihi2")


REFERENCE = "Intel Lava 0.10"


def lava_gaps(options: Mapping[str, Any], schedule: str) -> tuple[tuple[str, str, bool], ...]:
    """What of a run of ``options`` on ``schedule`` Lava does not run: (the setting, why,
    whether ``lava verify`` can still replay the learning in Lava) for each."""
    config = make_config(**options)
    gaps = []
    if schedule == "walk":
        gaps.append(("--schedule walk", "the engine's accumulator kept across a walk's steps, "
                     "one write-back a walk (Lava applies the rule once per epoch of at most "
                     "63 steps)", False))
    if schedule != "walk" and config.t_epoch > 1:
        gaps.append((f"--t-epoch {config.t_epoch}", "the terms of an epoch's steps summed "
                     "into one write-back (Lava's LearningDense applies the rule to the "
                     "epoch's last traces alone)", False))
    if config.draws == "independent":
        gaps.append(("--draws independent", "a rounding draw per synapse (Lava draws one per "
                     "epoch)", False))
    if config.terms == "exact":
        gaps.append(("terms=exact", "exact update terms, not the engine's", False))
    if config.traces == "stochastic":
        gaps.append(("traces=stochastic", "neurons that dither their graded spikes "
                     "(microcode Lava's neuron models lack; the learning itself runs in "
                     "Lava)", True))
    return tuple(gaps)


def beyond_lava(options: Mapping[str, Any], schedule: str) -> tuple[str, ...]:
    """What of a run of ``options`` on ``schedule`` Lava does not run, one sentence each
    (the ``beyond_reference`` of ``train``, ``emulate`` and ``export``;
    docs/devices/loihi2.md)."""
    return tuple(f"{setting}: {why}" for setting, why, _ in lava_gaps(options, schedule))


KNOBS = (
    Knob("bits", "num_weight_bits", 1, 8, "high", integer=True,
         doc="loihi2: weight bits, num_weight_bits (1..8)"),
)
"""What a break point can sweep on Loihi 2 (``cml-edge scenario breakpoint --knob``)."""

COST = CostModel("loihi2", "int8_mac", ("macs", "update_macs"), "sram_byte",
                 ("bytes_read", "bytes_written"))
"""Loihi 2's cost model (cml_edge.costs.ledger.COSTS): no per-operation energy of its
synaptic ops and learning engine is public in this form; the int8 MAC (8-bit weights) and
the SRAM byte are the closest sourced figures."""


# the kernels' parameter record ---------------------------------------------------------
Loihi2Params = kernel_record(Loihi2Config, "Loihi2Params", __name__, derived={
    "exp": int,  # weight_exp E: a read's sum is shifted by E, then by 6 into u
    "scale_exp": int,  # a weight w stands for w 2^(E - scale_exp)
    "nb": int,  # num_weight_bits
    "shift": int,  # bits truncate_weights drops: 8 - nb (+1 mixed); mantissa = w >> shift
    "w_min": int,  # clip_weights range (9-bit): mixed -256, excitatory 0, inhibitory -255
    "w_max": int,  # mixed 255, excitatory 255, inhibitory 0
    "msg_qmax": int,  # largest payload magnitude, 2^(num_message_bits - 1) - 1
    "l1_max": int,  # safe payload scale: the largest L1 norm of a payload vector
})


def payload_l1_max(exp: int) -> int:
    """The largest L1 norm of payloads s whose read cannot overflow the 24-bit neuron
    input for any weights |w| <= 256: with E = exp, |sum w s| <= 256 L1 and the input is
    floor(sum 2^E) 2^6 (E < 0) or sum 2^(E + 6); it stays within +-(2^23 - 64) when
    256 L1 2^E <= 2^17 - 1."""
    room = (1 << (U_BITS - 1 - ACT_SHIFT)) - 1  # 2^17 - 1
    if exp >= 0:
        return room >> (8 + exp)
    return (room << -exp) >> 8


def loihi2_params(config: Loihi2Config, exp: int, scale_exp: int, nb: int) -> Any:
    """The :class:`Loihi2Params` of an array at weight exponent ``exp``, float scale
    ``scale_exp`` and ``nb`` weight bits."""
    w_min, w_max = weight_limits(config.sign_mode, 8)
    shift = 8 - nb + (1 if config.sign_mode == "mixed" else 0)
    return build_record(Loihi2Params, config, exp=exp, scale_exp=scale_exp, nb=nb,
                        shift=shift, w_min=w_min, w_max=w_max,
                        msg_qmax=(1 << (config.num_message_bits - 1)) - 1,
                        l1_max=payload_l1_max(exp))


def check_scale(scale_exp: int, what: str) -> int:
    if not -SCALE_LIMIT <= scale_exp <= SCALE_LIMIT:
        raise InputError(f"{what}: float scale 2^{scale_exp} is beyond 2^+-{SCALE_LIMIT} "
                         "(allowed: weights within float64's range)")
    return scale_exp


__all__ = ["COST", "DRAWS", "KNOBS", "LEARNED_GAIN", "MAPPINGS", "TERMS", "MAX_MESSAGE_BITS",
           "MAX_T_EPOCH", "MAX_WEIGHT_EXP", "MIN_WEIGHT_EXP", "PAYLOAD_SCALES", "PRESETS", "TRACES",
           "Loihi2Config", "Loihi2Params", "check_scale", "loihi2_params", "make_config",
           "payload_l1_max"]
