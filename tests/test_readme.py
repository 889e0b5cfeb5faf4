"""The README's first two commands are the set-up the project promises."""

import shlex
from pathlib import Path

from cml_edge.cli import build_parser, main

ROOT = Path(__file__).resolve().parent.parent


def _commands() -> list[str]:
    lines = (ROOT / "README.md").read_text().splitlines()
    assert lines[0].startswith("```")
    return lines[1:3]


def test_ci_runs_the_readme_test_command():
    main_job, test_command = _commands()
    assert "pytest" in test_command and "pip install" in test_command
    assert "sed -n '3p' README.md" in (ROOT / ".ci" / "run").read_text()


def test_main_job_parses_and_runs_at_small_scale(capsys):
    main_job, _ = _commands()
    argv = shlex.split(main_job.split("&&", 1)[1])
    assert argv[0] == "cml-edge"
    build_parser().parse_args(argv[1:])  # the exact command is valid
    small = ["--seeds", "1", "--trials", "5", "--walks", "5", "--steps", "100", "--json"]
    assert main(argv[1:] + small) == 0
    assert '"success_rate"' in capsys.readouterr().out
