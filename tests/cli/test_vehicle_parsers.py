"""The robot's and the drone's ``train | evaluate | navigate`` parsers come from one builder
(:func:`cml_edge.cli.vehicle.add_vehicle_parsers`): a vehicle's own words and options land
where the builder puts them, and the two vehicles' shared options are alike."""

from __future__ import annotations

import argparse
from types import SimpleNamespace

from cml_edge.cli import build_parser
from cml_edge.cli.vehicle import Vehicle, add_vehicle_parsers


def _commands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    return next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices


def _options(parser: argparse.ArgumentParser) -> dict[str, tuple]:
    """Each option's flag: its default, choices, values taken, names and help."""
    return {a.option_strings[-1] if a.option_strings else a.dest:
            (a.default, a.choices, a.nargs, a.metavar, a.help) for a in parser._actions}


def _toy() -> tuple[argparse.ArgumentParser, Vehicle]:
    def own(flag):
        return lambda p: p.add_argument(flag, default="mine")

    vehicle = Vehicle(
        name="boat", help="a boat", run=lambda args: {},
        commands={"train": ("train a boat", print), "evaluate": ("sail away", print),
                  "navigate": ("sail to a few goals", print)},
        plot="a map of the voyages", moves="sails", axes=("E", "N"), exact="exact waves",
        mujoco={"drag": "hull drag"}, mujoco_defaults=SimpleNamespace(drag=0.5),
        utility="raw", train_options=own("--keel"), planning_options=own("--harbour"))
    top = argparse.ArgumentParser()
    add_vehicle_parsers(top.add_subparsers(dest="command"), vehicle)
    return top, vehicle


def test_a_vehicle_gets_its_words_and_its_own_options_where_the_builder_puts_them():
    top, vehicle = _toy()
    args = top.parse_args(["boat", "navigate", "m.npz", "--goal", "1", "2"])
    assert args.boat_command == "navigate" and args.goal == [1.0, 2.0]
    assert args.run is vehicle.run and args.show is print and args.harbour == "mine"
    commands = _commands(_commands(top)["boat"])
    train = list(_options(commands["train"]))
    assert train.index("--sim") < train.index("--keel") < train.index("--utility")
    assert _options(commands["train"])["--utility"][0] == "raw"
    navigate = _options(commands["navigate"])
    assert navigate["--goal"][2:4] == (2, ("E", "N"))
    assert navigate["--model-index"][4] == "which model of the file sails (0)"
    assert navigate["--plot"][4] == "a map of the voyages"
    assert navigate["--mujoco-drag"][4] == "hull drag (default 0.5)"
    assert "exact waves" in navigate["--sim"][4] and "--keel" not in navigate
    assert list(_options(commands["evaluate"]))[-1] == "--harbour"


def test_the_robot_and_the_drone_share_their_options_but_their_own():
    worlds = _commands(build_parser())
    robot, drone = (_commands(worlds[w]) for w in ("robot", "drone"))
    own = {"--goal", "--model-index", "--plot", "--sim", "--stop", "--radius", "model",
           "--base", "--start", "--observation", "--goal-heading"}
    for command in ("evaluate", "navigate"):
        r, d = _options(robot[command]), _options(drone[command])
        shared = {k: v for k, v in r.items() if k not in own and not k.startswith("--mujoco")}
        assert shared == {k: v for k, v in d.items()
                          if k not in own and not k.startswith("--mujoco")}
    assert _options(robot["navigate"])["--goal"][2] == 2
    assert _options(drone["navigate"])["--goal"][2] == 3
