"""The README's promises: its two set-up commands, CI running the second verbatim, and a
tour whose every command runs as written, in order, from any folder."""

from __future__ import annotations

import os
import re
import shlex
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from cml_edge.cli import build_parser, main

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
EXTRA = re.compile(r"\(extra: (\w+)\)")



def _setup_commands() -> list[str]:
    lines = README.read_text().splitlines()
    assert lines[0] == "```bash"
    return lines[1:3]


def tour() -> list[str]:
    """The lines of the README's tour: the first ```bash block after '## A tour'."""
    text = README.read_text()
    start = text.index("\n## A tour")
    block = re.search(r"```bash\n(.*?)```", text[start:], re.S)
    assert block, "the tour has no bash block"
    return [line for line in block.group(1).splitlines() if line.strip()]


def _split(line: str) -> list[str]:
    return shlex.split(line, comments=True)


def test_test_command_installs_the_test_extra_and_runs_everything():
    _, test_command = _setup_commands()
    install, sep, run = test_command.partition(" && ")
    assert sep, "line 3 is two commands joined by &&"
    assert shlex.split(install)[:2] == ["pip", "install"]
    assert ".[test]" in shlex.split(install)
    argv = shlex.split(run)
    assert argv[:3] == ["python", "-m", "pytest"] and "--slow" in argv


def _stub(folder: Path, name: str) -> None:
    path = folder / name
    path.write_text(f'#!/bin/sh\necho "{name} $*" >> "$STUB_LOG"\n')
    path.chmod(path.stat().st_mode | stat.S_IEXEC)


def _run_ci(tmp_path: Path, readme: str) -> tuple[int, list[str]]:
    """``.ci/run`` in a copy of the repository's top with ``python`` and ``pip`` stubbed
    out: its exit status and the commands it ran, one per line."""
    (tmp_path / ".ci").mkdir(parents=True)
    (tmp_path / ".ci" / "run").write_text((ROOT / ".ci" / "run").read_text())
    (tmp_path / "README.md").write_text(readme)
    stubs = tmp_path / "bin"
    stubs.mkdir()
    for name in ("python", "pip"):
        _stub(stubs, name)
    (tmp_path / "scripts").mkdir()
    for script in (ROOT / "scripts").glob("*.sh"):  # the environments' builders: logged
        _stub(tmp_path / "scripts", script.name)
    log = tmp_path / "log"
    log.touch()
    env = dict(os.environ, PATH=f"{stubs}{os.pathsep}{os.environ['PATH']}",
               STUB_LOG=str(log))
    proc = subprocess.run(["bash", str(tmp_path / ".ci" / "run")], env=env,
                          capture_output=True, text=True)
    return proc.returncode, log.read_text().splitlines()


def test_ci_runs_readme_line_3_verbatim(tmp_path):
    _, test_command = _setup_commands()
    code, ran = _run_ci(tmp_path / "ok", README.read_text())
    assert code == 0
    wanted = [" ".join(shlex.split(part)) for part in test_command.split(" && ")]
    found = [i for i, line in enumerate(ran) if line in wanted]
    assert [ran[i] for i in found] == wanted, ran  # both parts, in order
    assert found[1] == found[0] + 1
    # a README whose line 3 is not the test command stops CI before anything is installed
    broken = README.read_text().replace(test_command, "echo no tests", 1)
    code, ran = _run_ci(tmp_path / "broken", broken)
    assert code != 0 and not any("pytest" in line for line in ran)


def test_main_job_parses_and_runs_at_small_scale(capsys):
    main_job, _ = _setup_commands()
    argv = shlex.split(main_job.split("&&", 1)[1])
    assert argv[0] == "cml-edge"
    build_parser().parse_args(argv[1:])  # the exact command is valid
    small = ["--seeds", "1", "--trials", "5", "--walks", "5", "--steps", "100", "--json"]
    assert main(argv[1:] + small) == 0
    assert '"success_rate"' in capsys.readouterr().out


def test_tour_commands_parse_and_name_their_extra(script):
    checker = script("docs/check_figures.py")
    for line in tour():
        argv = _split(line)
        assert argv[0] == "cml-edge", line
        build_parser().parse_args(argv[1:])
        named = EXTRA.search(line)
        assert (named.group(1) if named else None) == checker.extra_of(argv), line
        for word in argv:
            assert not word.startswith(("/", "cml_edge/", "hw_reports/")), (
                f"{line}: reads or writes a path outside the current folder")


@pytest.fixture(scope="module")
def tour_folder(tmp_path_factory):
    return tmp_path_factory.mktemp("tour")


@pytest.mark.slow
@pytest.mark.parametrize("line", tour(), ids=[f"{i:02d}-{'-'.join(_split(line)[1:3])}"
                                              for i, line in enumerate(tour(), 1)])
def test_tour_command_runs_verbatim(line, tour_folder, script):
    """Each tour command, in order, from a folder outside the repository, with the
    checkout's package; a command of an optional extra is skipped where it is not
    installed."""
    checker = script("docs/check_figures.py")
    argv = _split(line)
    extra = checker.extra_of(argv)
    if extra and not checker.extra_installed(extra):
        pytest.skip(f"extra {extra} is not installed")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p))
    proc = subprocess.run([sys.executable, "-c", checker.RUNNER, *argv[1:]], cwd=tour_folder,
                          env=env, capture_output=True, text=True)
    assert proc.returncode == 0, f"{line}\n{proc.stderr[-3000:]}"
