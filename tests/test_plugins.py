"""Plugins: devices from the user's own files and modules, found by --plugin,
CML_EDGE_PLUGINS or an entry point; one line for anything wrong, the rest working; a model
that names its plugin; and an install no plugin can break."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from cml_edge.backends import BACKENDS, DEVICES, plugins, unregister_device

ROOT = Path(__file__).resolve().parent.parent
DEVICE_FILE = textwrap.dedent('''
    """A test plugin: exact float weights under the name {name}."""
    from cml_edge.kit import Device

    DEVICE = Device("{name}")
''')


@pytest.fixture
def fresh(monkeypatch):
    """The plugin registry as a new process has it, restored after the test."""
    monkeypatch.setattr(plugins, "LOADED", {})
    monkeypatch.setattr(plugins, "_ENVIRONMENT_LOADED", False)
    monkeypatch.delenv(plugins.ENV, raising=False)
    monkeypatch.setattr(plugins, "_entry_points", lambda: [])
    before = set(DEVICES)
    modules = set(sys.modules)
    yield
    for name in set(DEVICES) - before:
        unregister_device(name)
    for name in set(sys.modules) - modules:
        if name.startswith("plug_"):
            del sys.modules[name]


def _plugin(folder: Path, stem: str, name: str | None = None, text: str | None = None) -> Path:
    path = folder / f"{stem}.py"
    path.write_text(text if text is not None else DEVICE_FILE.format(name=name or stem))
    return path


SMALL = ["--arena", "8", "--walks", "2", "--steps", "30"]


def test_a_plugin_file_trains_evaluates_and_names_itself_in_its_model(fresh, cli, tmp_path):
    path = _plugin(tmp_path, "plug_a", "plug-a")
    model = tmp_path / "a.npz"
    code, _, err = cli("--plugin", path, "train", "--backend", "plug-a", *SMALL, "--out", model)
    assert code == 0, err
    assert "checking the device 'plug-a'" in err or "plug-a" in DEVICES
    assert DEVICES["plug-a"].origin == str(path)
    with np.load(model) as z:
        assert str(z["W_q/__origin__"]) == str(path)
    code, out, err = cli("evaluate", model, "--trials", 3, "--json")
    assert code == 0, err  # loaded in this process already
    unregister_device("plug-a")
    plugins.LOADED.clear()
    code, _, err = cli("evaluate", model, "--trials", 3)
    assert code == 2 and err.count("\n") == 1
    assert f"comes from the plugin '{path}', which is not loaded: give cml-edge --plugin " \
           f"{path}" in err


def test_a_plugin_is_checked_once_per_version(fresh, tmp_path, capsys):
    path = _plugin(tmp_path, "plug_b", "plug-b")
    assert plugins.load(str(path)) == ["plug-b"]
    assert plugins.load(str(path)) == ["plug-b"]  # twice: nothing more
    stamp = plugins._stamp(DEVICES["plug-b"], plugins._source(sys.modules["plug_b"], ""))
    assert stamp.is_file()


@pytest.mark.parametrize("text, message", [
    ("import nothing_of_the_kind\n", r"plugin '.*plug_c\.py' failed to import \(line 1\): "
                                     r"ModuleNotFoundError: No module named "
                                     r"'nothing_of_the_kind'"),
    ("x = 1\n", r"plugin '.*plug_c\.py' defines no device"),
    ("from cml_edge.kit import Device\nDEVICE = Device('float')\n",
     r"device 'float': name 'float' is taken \(by a built-in device\)"),
    ("from cml_edge.kit import Device\n\ndef write(p, w, dw):\n    return w - dw\n\n"
     "DEVICE = Device('plug-c', write=write)\n",
     r"plugin '.*plug_c\.py': device 'plug-c' \(plug-c, 24 x 12\) breaks the update rule"),
    ("from cml_edge.kit import Device\nDEVICE = Device('Plug C')\n",
     r"plugin '.*plug_c\.py': device name 'Plug C' is not a lower-case name"),
])
def test_a_broken_plugin_is_one_line_and_the_rest_works(fresh, cli, tmp_path, text, message):
    path = _plugin(tmp_path, "plug_c", text=text)
    code, _, err = cli("--plugin", path, "train", "--backend", "float", *SMALL, "--out",
                       tmp_path / "x.npz")
    errors = [line for line in err.splitlines() if line.startswith("cml-edge: error: ")]
    assert code == 2 and len(errors) == 1 and "Traceback" not in err
    assert re.search(message, errors[0]), err
    assert not (tmp_path / "x.npz").exists()
    assert "plug-c" not in BACKENDS and "plug_c" not in sys.modules
    # from the environment it is a warning, and the built-in device still trains
    os.environ[plugins.ENV] = str(path)
    try:
        code, _, err = cli("train", "--backend", "float", *SMALL, "--out", tmp_path / "y.npz")
    finally:
        del os.environ[plugins.ENV]
    assert code == 0 and "cml-edge: warning:" in err and "left out" in err


def test_plugins_from_the_environment_and_entry_points(fresh, tmp_path, monkeypatch):
    first = _plugin(tmp_path, "plug_d", "plug-d")
    monkeypatch.syspath_prepend(str(tmp_path))
    _plugin(tmp_path, "plug_e", "plug-e")

    class EntryPoint:
        name, value = "e", "plug_e"

        def load(self):
            import plug_e

            return plug_e

    monkeypatch.setattr(plugins, "_entry_points", lambda: [("plug_e (entry point)",
                                                            EntryPoint())])
    monkeypatch.setenv(plugins.ENV, os.pathsep.join([str(first), "plug_missing_module"]))
    lines = plugins.load_environment(warn=False)
    assert "plug-d" in DEVICES and "plug-e" in DEVICES
    assert DEVICES["plug-e"].origin == "plug_e"
    assert len(lines) == 1 and "plugin 'plug_missing_module' does not import" in lines[0]
    assert plugins.load_environment() == []  # once per process


def test_a_name_not_registered_loads_the_environment(fresh, tmp_path, monkeypatch):
    from cml_edge.backends import backend_spec

    monkeypatch.setenv(plugins.ENV, str(_plugin(tmp_path, "plug_f", "plug-f")))
    assert backend_spec("plug-f").device.name == "plug-f"


def test_the_command_names_are_the_parsers():
    import argparse

    from cml_edge.cli import COMMANDS, build_parser

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    assert set(sub.choices) == COMMANDS
    assert plugins.given(["--plugin", "a.py", "--plugin=b", "train", "--plugin", "c"],
                         COMMANDS) == ["a.py", "b"]


BUILT_IN = ("float", "float32", "int8", "int16", "loihi2", "crossbar")


@pytest.mark.slow
def test_removing_a_plugin_leaves_every_built_in_command_working(tmp_path):
    """A plugin device's training and planning loops compiled into the shared kernel
    cache, its file removed: every built-in device still trains and evaluates, in the same
    install and cache, with no traceback (Numba's index of a shared loop must not name the
    plugin's classes: jit/cache_scope.py)."""
    name = f"plug-gone-{os.getpid()}"
    path = _plugin(tmp_path, "plug_gone", name)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    env.pop(plugins.ENV, None)

    def cml_edge(*argv):
        return subprocess.run([sys.executable, "-c", "import sys; from cml_edge.cli import "
                               "main; sys.exit(main(sys.argv[1:]))", *map(str, argv)],
                              cwd=tmp_path, env=env, capture_output=True, text=True)

    for command in (["train", "--backend", name, *SMALL, "--out", "p.npz"],
                    ["evaluate", "p.npz", "--trials", "3"]):
        done = cml_edge("--plugin", path, *command)
        assert done.returncode == 0, done.stderr
    path.unlink()
    for backend in BUILT_IN:
        for command in (["train", "--backend", backend, *SMALL, "--out", f"{backend}.npz"],
                        ["evaluate", f"{backend}.npz", "--trials", "3"]):
            done = cml_edge(*command)
            assert done.returncode == 0 and "Traceback" not in done.stderr, \
                (backend, command, done.stderr[-2000:])


def test_the_report_runs_a_plugins_device_when_asked(fresh, cli, tmp_path, monkeypatch):
    import cml_edge.report as report

    path = _plugin(tmp_path, "plug_r", "plug-r")
    seen = {}

    def build_report(**kwargs):
        seen.update(kwargs)
        raise SystemExit(0)

    monkeypatch.setattr(report, "build_report", build_report)
    with pytest.raises(SystemExit):
        cli("--plugin", path, "report", "--out", tmp_path / "r", "--with", "plug-r",
            "--with", "int8")
    systems = [s[0] for s in seen["systems"]]
    assert systems.count("plug-r") == 1 and systems.count("int8") == 1  # int8: already in
    assert ("plug-r", "plug-r", {}) in seen["scorecard"].devices
    code, _, err = cli("report", "--out", tmp_path / "r2", "--with", "nope")
    assert code == 2 and "unknown backend 'nope'" in err


@pytest.mark.slow
def test_a_plugins_device_in_the_other_commands(fresh, cli, tmp_path):
    """emulate with chips, a scenario, a sweep's device list and the bench take it."""
    import json

    from cml_edge.backends import configurations

    plugin = "cml_edge.kit.examples.ternary"
    code, out, err = cli("--plugin", plugin, "emulate", "--backend", "ternary", "--chips", 3,
                         "--seeds", 1, *SMALL, "--trials", 5, "--json")
    assert code == 0, err
    assert json.loads(out)["chips"]["n"] == 3
    code, out, err = cli("--plugin", plugin, "scenario", "paper", "--backend", "ternary",
                         "--seeds", 1, "--quick", "--out", tmp_path / "s", "--json")
    assert code == 0, err
    assert ("ternary", "ternary", {}) in configurations()
    code, out, err = cli("--plugin", plugin, "bench", "--backends", "ternary", "--repeats", 1,
                         "--json")
    assert code == 0, err
    assert "ternary" in json.loads(out)["backends"]
