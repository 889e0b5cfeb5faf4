"""Shared fixtures (small arenas and configurations that keep the suite fast) and the
``slow`` marker: ``python -m pytest`` skips the tests marked slow, ``--slow`` (what CI and
the README's test command run) runs everything."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

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


ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture
def script():
    """A script of the checkout loaded as a module: ``script("docs/check_figures.py")``
    (registered in ``sys.modules`` under its file's stem, for its dataclasses)."""

    def load(relative: str):
        path = ROOT / relative
        spec = importlib.util.spec_from_file_location(path.stem, path)
        module = importlib.util.module_from_spec(spec)
        sys.modules.setdefault(path.stem, module)
        spec.loader.exec_module(module)
        return module

    return load


@pytest.fixture
def cli(capsys):
    """``cml-edge`` run in-process: ``cli(*argv)`` -> (exit status, stdout, stderr)."""
    from cml_edge.cli import main

    def run(*argv):
        code = main([str(a) for a in argv])
        out, err = capsys.readouterr()
        return code, out, err

    return run


@pytest.fixture
def cli_json(cli):
    """``cli_json(*argv)``: the JSON ``cml-edge ... --json`` prints (the run must succeed)."""
    import json

    def run(*argv):
        code, out, err = cli(*argv, "--json")
        assert code == 0, err
        return json.loads(out)

    return run


@pytest.fixture
def cli_bad(cli):
    """``cli_bad(*argv)``: the one error line of a run refused as bad input (exit 2, nothing
    on stdout)."""

    def run(*argv):
        code, out, err = cli(*argv)
        assert code == 2 and out == "", (code, out, err)
        return err.strip().splitlines()[-1]

    return run


def pytest_addoption(parser):
    parser.addoption("--slow", action="store_true",
                     help="also run the tests marked slow (CI runs everything)")


def pytest_configure(config):
    config.addinivalue_line("markers", "slow: a test that takes seconds to minutes; run "
                            "with --slow")


def pytest_collection_modifyitems(config, items):
    if config.getoption("--slow"):
        return
    skip = pytest.mark.skip(reason="slow: run with --slow")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip)
