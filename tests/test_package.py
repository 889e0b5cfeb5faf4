"""The package as a whole: what ``import cml_edge`` does, and the shape of its import graph."""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

import pytest

import cml_edge

ROOT = Path(cml_edge.__file__).parent


def run_python(code: str) -> dict:
    """``code`` in a fresh interpreter importing this checkout; the JSON it prints last."""
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT.parent, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.splitlines()[-1])


MAKE_EACH = """
import gymnasium
made = {}
for env_id in cml_edge.GYMNASIUM_ENVS:
    env = gymnasium.make(env_id)
    obs, info = env.reset(seed=0)
    made[env_id] = env.observation_space.contains(obs)
    env.close()
print(json.dumps({"before": before, "registered": sorted(gymnasium.registry), "made": made}))
"""


@pytest.mark.parametrize("gymnasium_first", [False, True])
def test_import_registers_the_gymnasium_ids_without_importing_gymnasium(gymnasium_first):
    """``import cml_edge`` leaves Gymnasium unimported; once it is imported (after
    cml_edge or before it), every id of ``GYMNASIUM_ENVS`` is registered and makes its
    environment."""
    pytest.importorskip("gymnasium", reason="the Gymnasium ids need the dqn extra")
    first = "import gymnasium\n" if gymnasium_first else ""
    out = run_python(f"import json, sys\n{first}import cml_edge\n"
                     "before = 'gymnasium' in sys.modules\n" + MAKE_EACH)
    assert out["before"] is gymnasium_first
    assert set(cml_edge.GYMNASIUM_ENVS) <= set(out["registered"])
    assert out["made"] == {env_id: True for env_id in cml_edge.GYMNASIUM_ENVS}


# the import graph ------------------------------------------------------------------------------
def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {module_name(p): p for p in ROOT.rglob("*.py")}


def resolve(name: str) -> str | None:
    """The package's module ``name`` is, or lies in (an imported function's module)."""
    while name not in MODULES:
        if "." not in name:
            return None
        name = name.rsplit(".", 1)[0]
    return name


def imports_of(module: str) -> set[str]:
    """The package's modules ``module`` imports, at module level or deferred in a function
    (a package's ``__init__`` imported on the way to its modules does not count)."""
    path = MODULES[module]
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(resolve(a.name) for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                base = f"{parent}.{base}" if base else parent
            for a in node.names:
                full = f"{base}.{a.name}"
                found.add(resolve(full) if full in MODULES else resolve(base))
    return found - {None, module}


GRAPH = {m: imports_of(m) for m in MODULES}


def test_the_graph_sees_module_level_and_deferred_imports():
    assert "cml_edge.core.cml" in GRAPH["cml_edge.grid.training"]  # module level
    assert "cml_edge.robot.fidelity" in GRAPH["cml_edge.cli.vehicle_commands"]  # deferred
    assert "cml_edge.backends.fixed.kernels" in GRAPH["cml_edge.backends.fixed.array"]  # submodule


def test_nothing_outside_the_command_line_imports_it():
    users = sorted(m for m, deps in GRAPH.items() if not m.startswith("cml_edge.cli")
                   and any(d == "cml_edge.cli" or d.startswith("cml_edge.cli.") for d in deps))
    assert users == []


def first_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """Depth-first search: the first chain of nodes that leads back to where it started,
    or None."""
    state: dict[str, int] = {}  # 1 on the current path, 2 done
    path: list[str] = []

    def visit(m: str) -> list[str] | None:
        state[m] = 1
        path.append(m)
        for d in sorted(graph.get(m, ())):
            if state.get(d) == 1:
                return path[path.index(d):] + [d]
            if d not in state and (cycle := visit(d)):
                return cycle
        state[m] = 2
        path.pop()
        return None

    return next((cycle for m in sorted(graph) if m not in state and (cycle := visit(m))),
                None)


def test_the_import_graph_has_no_cycle():
    """A cycle is reported as the chain of modules that closes it."""
    cycle = first_cycle(GRAPH)
    assert cycle is None, " -> ".join(cycle)


def subpackage(module: str) -> str:
    """``cml_edge.grid.maps`` -> ``cml_edge.grid``; a top-level module is its own."""
    return ".".join(module.split(".")[:2])


PACKAGE_GRAPH: dict[str, set[str]] = {}
for _m, _deps in GRAPH.items():
    PACKAGE_GRAPH.setdefault(subpackage(_m), set()).update(
        subpackage(d) for d in _deps if subpackage(d) != subpackage(_m))


def test_the_subpackages_import_one_another_without_a_cycle():
    """Layers, not a web: no chain of subpackages (core -> backends -> ... -> core) leads
    back to where it started, at module level or through a deferred import. Reported as
    the chain and, for its first link, the modules that make it."""
    cycle = first_cycle(PACKAGE_GRAPH)
    if cycle is not None:
        a, b = cycle[0], cycle[1]
        links = sorted(f"{m} -> {d}" for m, deps in GRAPH.items() if subpackage(m) == a
                       for d in deps if subpackage(d) == b)
        pytest.fail(" -> ".join(cycle) + f" (first link: {', '.join(links)})")


def test_the_engine_imports_nothing_above_it():
    """engine/ runs tasks, stops and timings: it knows no command, option or scenario."""
    assert PACKAGE_GRAPH["cml_edge.engine"] <= {"cml_edge", "cml_edge.core", "cml_edge.errors",
                                                "cml_edge.io", "cml_edge.jit",
                                                "cml_edge.protocol", "cml_edge.sizes"}
