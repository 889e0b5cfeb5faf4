"""The estimate off the plane's king moves: a step priced by the CML's weights in the world
run (4,608 on the plane, 14,080 in the volume with 26 king moves, 3,840 with 6 face moves),
and a scenario sized by its runs in that world."""

from __future__ import annotations

import pytest

from cml_edge.cli import build_parser, limits

VOLUME, FACE = 14_080 / 4_608, 3_840 / 4_608


def est(*argv) -> limits.Estimate:
    return limits.estimate(build_parser().parse_args([str(a) for a in argv]))


def test_a_scenario_in_the_volume_is_priced_by_its_runs_there():
    plane = est("scenario", "paper", "--seeds", 2)
    volume = est("scenario", "paper", "--seeds", 2, "--dims", 3)
    assert volume.seconds == pytest.approx(VOLUME * plane.seconds)
    face = est("scenario", "paper", "--seeds", 2, "--dims", 3, "--moves", "face")
    assert face.seconds == pytest.approx(FACE * plane.seconds)
    # large: two runs on the plane, one in the volume (of as many plans as the paper's)
    assert est("scenario", "large", "--seeds", 2).seconds > 1.5 * plane.seconds
    assert est("scenario", "large", "--seeds", 2, "--dims", 3).seconds == pytest.approx(
        volume.seconds)
    bp = est("breakpoint", "--scenario", "paper", "--knob", "bits", "--seeds", 2, "--dims", 3)
    assert bp.seconds == pytest.approx(limits.BREAKPOINT_RUNS * volume.seconds)
    assert est("scenario", "robot", "--seeds", 2, "--dims", 3).seconds == 0  # refused later


def test_a_command_off_the_plane_prices_its_steps_there():
    plane = est("train", "--out", "m.npz")
    assert est("train", "--dims", 3, "--out", "m.npz").seconds == pytest.approx(
        VOLUME * plane.seconds)
