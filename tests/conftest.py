"""Shared fixtures: small arenas and configurations that keep the suite fast."""

from __future__ import annotations

import pytest

from cml_edge.core.cml import CMLConfig
from cml_edge.grid.arena import GridArena
from cml_edge.grid.training import TrainConfig


@pytest.fixture
def small_arena() -> GridArena:
    return GridArena.empty(10)


@pytest.fixture
def small_config() -> CMLConfig:
    return CMLConfig.for_arena(10)


@pytest.fixture
def short_training() -> TrainConfig:
    return TrainConfig(walks=4, steps=60)


@pytest.fixture
def cli(capsys):
    """``cml-edge`` run in-process: ``cli(*argv)`` -> (exit status, stdout, stderr)."""
    from cml_edge.cli import main

    def run(*argv):
        code = main([str(a) for a in argv])
        out, err = capsys.readouterr()
        return code, out, err

    return run
