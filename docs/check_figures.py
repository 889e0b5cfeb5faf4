"""Rerun the docs' seeded figures and report every one that no longer matches its command.

    python docs/check_figures.py [PAGE ...] [--list] [--rerun] [--grep TEXT]
                                 [--estimate] [--quick]

A seeded figure carries a marker, an HTML comment right above its table or sentence:

    <!-- figure[ row N | rows N-M][ col K | cols K-L]: COMMAND -> VALUES [@ FILE] -->
    <!-- timing: COMMAND -->

- COMMAND is a ``cml-edge`` command line, or several joined by `` && `` (run in order, in
  one fresh temporary folder; the last one's output is read). It runs with the checkout's
  package (``PYTHONPATH`` = the repository root).
- VALUES are JSON keys of that output, each ``KEY[:FORMAT]``: KEY a dotted path
  (``weight_error.matrix_mean.mean``), where ``name[3]`` indexes a list and
  ``name[part=1y,device=int8]`` picks the first object of a list (or of an object's
  values) with those fields; FORMAT a
  Python format spec (default ``.3f``; ``,d`` for 57,726; ``.2e`` for 1.10e9).
  ``PREFIX.{a b:.4f}`` is short for ``PREFIX.a PREFIX.b:.4f``. Groups of values are
  separated by ``|`` or a new line: one group per table row.
- Without ``@ FILE`` the command must print JSON (``--json``). With it, the values are
  read from FILE, the JSON the command made: by default the copy committed in the
  repository (nothing runs: the page is checked against its results file); with
  ``--rerun`` the command runs, and its JSON is read from its output (``--json``) or
  else from the file it writes at FILE.
- The target is the next paragraph or table below the marker(s); ``row N`` / ``rows N-M``
  are data rows of the table below (1 = the first after the header), ``col K`` / ``cols
  K-L`` its cells. Each group's formatted values must appear, in order, among the numbers
  of its target (a table row, or the whole paragraph).
- A timing figure is not seeded: it is listed, never run or checked.

A value that matches only within the tolerance a seed promises across machines
(``cml_edge/core/machines.py``: a figure computed on another CPU may round the other way in its
last printed digit) is reported as "matches (other CPU)".

Prints one line per figure (match, MISMATCH, error, skipped when the command needs an
optional extra that is not installed, or timing) with the seconds its command took, and
exits 1 if any figure does not match or its command fails.

``--estimate`` runs nothing: it prints how long each command would take and the total,
from the commands' sizes (``cml_edge/cli/limits.py``'s estimate, the one ``cml-edge``
prints before a long run, plus :data:`START_S` for each fresh process): a figure read from
a committed results file costs nothing unless ``--rerun``; a command whose work that
estimate does not read (:data:`UNPRICED`: a report, a sweep's experiments, Lava) is
listed as not priced; the first compile of the kernels (5-10 min, once) is not counted.
``--quick`` checks the figures read from committed results files (nothing runs) and those
of the :data:`QUICK_COMMANDS` fastest priced commands, a sample that runs in minutes.
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import importlib.util
import json
import math
import os
import re
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # the checkout's package
from cml_edge.core.machines import ABS, REL  # noqa: E402

RUNNER = "import sys; from cml_edge.cli import main; sys.exit(main(sys.argv[1:]))"
MARKER = re.compile(r"<!--\s*(figure|timing)\b(.*?)-->", re.S)
HEAD = re.compile(r"^(?:\s+rows?\s+(\d+)(?:-(\d+))?)?(?:\s+cols?\s+(\d+)(?:-(\d+))?)?\s*:\s*(.*)$",
                  re.S)
NUMBER = re.compile(r"n/a|inf|(?<![\w.])-?\d[\d,]*(?:\.\d+)?(?:[eE][-+]?\d+)?")
FORMAT = re.compile(r"^[<>=^]?[+\- ]?#?0?\d*[,_]?(?:\.\d+)?[bdeEfFgGn%]?$")
START_S = 3.0
"""A fresh ``cml-edge`` process's start: Python, the package and its cached kernels loaded
(the warm main job took 4.5-5.1 s, of which its estimate prices 2.4: benchmarks/README.md)."""
UNPRICED = ("report", "sweep", "lava")
"""The commands whose work :func:`cml_edge.cli.limits.estimate` does not read from their
options (a whole report, an experiment's grid, Lava's own process): not priced."""
QUICK_COMMANDS = 5
"""How many of the fastest priced commands ``--quick`` runs."""
EXTRAS = {"dqn": ("torch", "stable_baselines3", "gymnasium"), "robot": ("mujoco", "gymnasium"),
          "distributed": ("distributed",)}
"""Optional extras (pyproject.toml) and the modules a command of each needs."""


@dataclasses.dataclass
class Value:
    key: str
    fmt: str = ".3f"

    def __str__(self) -> str:
        return f"{self.key}:{self.fmt}"


@dataclasses.dataclass
class Figure:
    page: Path
    line: int
    kind: str  # "figure" or "timing"
    command: str
    groups: list[list[Value]] = dataclasses.field(default_factory=list)
    targets: list[tuple[int, str]] = dataclasses.field(default_factory=list)
    file: str | None = None

    @property
    def where(self) -> str:
        try:
            page = self.page.resolve().relative_to(ROOT)
        except ValueError:
            page = self.page
        return f"{page}:{self.line}"

    def argvs(self) -> list[list[str]]:
        """The command's parts, each as an argv starting with ``cml-edge``."""
        return [shlex.split(part) for part in self.command.split(" && ")]


class MarkerError(ValueError):
    """A marker that does not parse, or whose target is missing."""


def extra_of(argv: list[str]) -> str | None:
    """The optional extra a ``cml-edge`` command needs, or None."""
    if argv[1:2] == ["dqn"]:
        return "dqn"
    if "--scheduler" in argv:
        return "distributed"
    if argv[1:2] in (["robot"], ["drone"]) and "mujoco" in argv:
        return "robot"
    return None


def extra_installed(extra: str) -> bool:
    return all(importlib.util.find_spec(m) is not None for m in EXTRAS[extra])


def _values(text: str) -> list[list[Value]]:
    groups = []
    for chunk in re.split(r"\n|\s\|\s", text):
        tokens = []
        for tok in re.findall(r"[^\s{]*\{[^}]*\}|\S+", chunk):
            if "{" in tok:
                prefix, inner = tok.split("{", 1)
                tokens += [prefix + item for item in inner.rstrip("}").split()]
            else:
                tokens.append(tok)
        values = []
        for tok in tokens:
            key, sep, fmt = tok.rpartition(":")
            if sep and "]" not in fmt and FORMAT.match(fmt):
                values.append(Value(key, fmt))
            else:
                values.append(Value(tok))
        if values:
            groups.append(values)
    return groups


def _skip_markers(lines: list[str], i: int) -> int:
    """The index of the first line at or after ``i`` that is neither blank nor a marker."""
    while i < len(lines) and (not lines[i].strip() or lines[i].lstrip().startswith("<!--")):
        if lines[i].lstrip().startswith("<!--"):
            while "-->" not in lines[i]:
                i += 1
        i += 1
    return i


def _table(lines: list[str], start: int) -> list[tuple[int, str]]:
    """The data rows (line number, text) of the table below the marker(s) ending at
    ``start``."""
    i = _skip_markers(lines, start)
    if i >= len(lines) or not lines[i].lstrip().startswith("|"):
        raise MarkerError(f"line {i + 1}: expected a table below the marker")
    rows = []
    for j in range(i + 2, len(lines)):
        if not lines[j].lstrip().startswith("|"):
            break
        rows.append((j + 1, lines[j]))
    return rows


def _block(lines: list[str], start: int) -> list[tuple[int, str]]:
    """The paragraph or table (line number, text) below the marker(s) ending at ``start``."""
    i = _skip_markers(lines, start)
    block = []
    while i < len(lines) and lines[i].strip() and not lines[i].lstrip().startswith("<!--"):
        block.append((i + 1, lines[i]))
        i += 1
    return block


def _cells(text: str, cols: tuple[int, int] | None) -> str:
    if cols is None:
        return text
    cells = text.strip().strip("|").split("|")
    return "|".join(cells[cols[0] - 1: cols[1]])


def _fenced(text: str) -> list[tuple[int, int]]:
    """Character spans of fenced code blocks (markers there are examples, not figures)."""
    spans, start, pos = [], None, 0
    for line in text.splitlines(keepends=True):
        if line.lstrip().startswith("```"):
            if start is None:
                start = pos
            else:
                spans.append((start, pos + len(line)))
                start = None
        pos += len(line)
    return spans


def parse_page(page: Path) -> list[Figure]:
    """Every figure and timing marker of a page, with its target lines."""
    text = page.read_text()
    lines = text.splitlines()
    fences = _fenced(text)
    figures = []
    for m in MARKER.finditer(text):
        if any(a <= m.start() < b for a, b in fences):
            continue
        line = text.count("\n", 0, m.start()) + 1
        end_line = text.count("\n", 0, m.end())  # 0-based index of the marker's last line
        if m.group(1) == "timing":
            command = " ".join(m.group(2).strip().lstrip(":").split())
            figures.append(Figure(page, line, "timing", command))
            continue
        head = HEAD.match(m.group(2))
        if head is None or " -> " not in head.group(5).replace("\n", " "):
            raise MarkerError(f"{page}:{line}: a figure marker reads "
                              f"'<!-- figure: COMMAND -> VALUES -->'")
        rows = (int(head.group(1)), int(head.group(2) or head.group(1))) if head.group(1) else None
        cols = (int(head.group(3)), int(head.group(4) or head.group(3))) if head.group(3) else None
        body = head.group(5)
        command, _, values = body.partition(" -> ") if " -> " in body else body.partition("->")
        file = None
        at = re.search(r"\s@\s*(\S+)\s*$", values)
        if at:
            file, values = at.group(1), values[: at.start()]
        fig = Figure(page, line, "figure", " ".join(command.split()), _values(values), [], file)
        if not fig.groups or not fig.command.startswith("cml-edge "):
            raise MarkerError(f"{fig.where}: a figure needs a cml-edge command and values")
        if rows is not None:
            try:
                table = _table(lines, end_line + 1)
            except MarkerError as exc:
                raise MarkerError(f"{fig.where}: {exc}") from None
            wanted = table[rows[0] - 1: rows[1]]
            if len(wanted) != rows[1] - rows[0] + 1 or len(fig.groups) != len(wanted):
                raise MarkerError(f"{fig.where}: rows {rows[0]}-{rows[1]} need as many value "
                                  f"groups ({len(fig.groups)}) and table rows ({len(table)})")
            fig.targets = [(n, _cells(t, cols)) for n, t in wanted]
        else:
            block = _block(lines, end_line + 1)
            if not block:
                raise MarkerError(f"{fig.where}: nothing below the marker")
            fig.targets = [(block[0][0], " ".join(_cells(t, cols) for _, t in block))]
            fig.groups = [[v for g in fig.groups for v in g]]
        figures.append(fig)
    return figures


def lookup(data: Any, key: str) -> Any:
    """The value at a dotted path (module docstring); a key of the data that itself holds
    dots (``weight_error.matrix_mean``) is matched as a whole."""
    parts = re.findall(r"[^.\[]+|\[[^\]]*\]", key)
    i = 0
    while i < len(parts):
        part = parts[i]
        if part.startswith("["):
            sel = part[1:-1]
            if re.fullmatch(r"-?\d+", sel):
                data = data[int(sel)]
            else:
                want = dict(kv.split("=", 1) for kv in sel.split(","))
                items = data.values() if isinstance(data, dict) else data
                found = [d for d in items if isinstance(d, dict)
                         and all(str(d.get(k)) == v for k, v in want.items())]
                if not found:
                    raise KeyError(f"no entry with {sel} in {key}")
                data = found[0]
        elif isinstance(data, list):
            data = data[int(part)]
        else:
            n = len(parts) - i
            while n > 1 and ".".join(parts[i:i + n]) not in data:
                n -= 1
            data = data[".".join(parts[i:i + n])]
            i += n - 1
        i += 1
    return data


def _normal(token: str) -> str:
    token = token.replace("−", "-")
    return re.sub(r"[eE]\+?(-?)0*(\d)", r"e\1\2", token)


def formatted(value: Any, fmt: str) -> str:
    """A value as the page prints it."""
    if value is None:
        return "n/a"
    if isinstance(value, float) and value != value:
        return "nan"
    if isinstance(value, float) and abs(value) == float("inf"):
        return "inf"
    if fmt.endswith("d") and isinstance(value, float) and value.is_integer():
        value = int(value)
    return _normal(format(value, fmt))


def readings(value: Any, fmt: str) -> list[str]:
    """How the page may print ``value``: as it is, then as the ends of the tolerance a
    seed promises across machines (``cml_edge.core.machines``: a figure computed on another CPU
    may differ in its last bits, and so round the other way)."""
    exact = formatted(value, fmt)
    if not isinstance(value, float) or not math.isfinite(value):
        return [exact]
    slack = REL * abs(value) + ABS
    return [exact, formatted(value - slack, fmt), formatted(value + slack, fmt)]


def compare(fig: Figure, data: Any) -> tuple[list[str], bool]:
    """The problems of a figure against its command's output (empty: it matches), and
    whether a value matched only within the cross-machine tolerance."""
    problems, other_cpu = [], False
    for (lineno, text), group in zip(fig.targets, fig.groups):
        try:
            want = [readings(lookup(data, v.key), v.fmt) for v in group]
        except (KeyError, IndexError, TypeError, ValueError, AttributeError) as exc:
            problems.append(f"line {lineno}: {exc!r}")
            continue
        have = [_normal(t) for t in NUMBER.findall(text)]
        pos = 0
        for v, w in zip(group, want):
            at = next((have.index(r, pos) for r in w if r in have[pos:]), None)
            if at is None:
                problems.append(f"line {lineno}: {v.key} gives {w[0]}; the page shows "
                                f"{' '.join(have) or 'no number'}")
                break
            other_cpu |= have[at] != w[0]
            pos = at + 1
    return problems, other_cpu


def _run(fig: Figure, rerun: bool, timeout: float | None) -> tuple[Any, float]:
    """The JSON a figure reads, and the seconds its command took (0 for a file)."""
    if fig.file and not rerun:
        return json.loads((ROOT / fig.file).read_text()), 0.0
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p))
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="check-figures-") as tmp:
        out = ""
        for argv in fig.argvs():
            if argv[0] != "cml-edge":
                raise RuntimeError(f"not a cml-edge command: {shlex.join(argv)}")
            proc = subprocess.run([sys.executable, "-c", RUNNER, *argv[1:]], cwd=tmp, env=env,
                                  capture_output=True, text=True, timeout=timeout)
            if proc.returncode != 0:
                tail = (proc.stderr.strip().splitlines() or ["(no output)"])[-1]
                raise RuntimeError(f"exit {proc.returncode}: {tail}")
            out = proc.stdout
        last = fig.argvs()[-1]
        data = (json.loads((Path(tmp) / fig.file).read_text())
                if fig.file and "--json" not in last else json.loads(out))
    return data, time.perf_counter() - t0


def _echo(line: str) -> None:
    print(line, flush=True)


def check(figures: list[Figure], rerun: bool = False, timeout: float | None = None,
          echo=_echo) -> int:
    """Run and compare every figure; returns the number that failed (mismatch or error)."""
    cache: dict[str, tuple[Any, float] | Exception] = {}
    first_run: dict[str, str] = {}
    counts = {"match": 0, "MISMATCH": 0, "error": 0, "skipped": 0, "timing": 0}
    for fig in figures:
        if fig.kind == "timing":
            counts["timing"] += 1
            echo(f"timing    {'':>8}  {fig.where}  {fig.command}  (not seeded: not checked)")
            continue
        extras = {extra_of(a) for a in fig.argvs()} - {None}
        missing = [e for e in extras if not extra_installed(e)]
        if missing and (rerun or not fig.file):
            counts["skipped"] += 1
            echo(f"skipped   {'':>8}  {fig.where}  {fig.command}  (extra {missing[0]} is "
                 f"not installed)")
            continue
        key = _key(fig)
        source = f"  @ {fig.file}" if fig.file and not rerun else ""
        if key in cache:
            source += f"  (same output as {first_run[key]})"
        else:
            first_run[key] = fig.where
            try:
                cache[key] = _run(fig, rerun, timeout)
            except (RuntimeError, OSError, json.JSONDecodeError,
                    subprocess.TimeoutExpired) as exc:
                cache[key] = exc
        got = cache[key]
        if isinstance(got, Exception):
            counts["error"] += 1
            echo(f"error     {'':>8}  {fig.where}  {fig.command}{source}\n    {got}")
            continue
        data, seconds = got
        if first_run[key] != fig.where:
            seconds = 0.0
        problems, other_cpu = compare(fig, data)
        status = "MISMATCH" if problems else "match"
        counts[status] += 1
        shown = "matches (other CPU)" if status == "match" and other_cpu else status
        echo(f"{shown:<9} {seconds:7.1f}s  {fig.where}  {fig.command}{source}")
        for p in problems:
            echo(f"    {p}")
    echo("; ".join(f"{n} {k.lower()}" for k, n in counts.items()))
    return counts["MISMATCH"] + counts["error"]


def seconds(fig: Figure, rerun: bool = False) -> float | None:
    """How long ``fig``'s command would take (module docstring: ``--estimate``); 0 for a
    figure read from its committed results file (without ``rerun``), None where a part
    of it is not priced."""
    if fig.kind == "timing" or (fig.file and not rerun):
        return 0.0
    from cml_edge.cli import limits

    total = 0.0
    for argv in fig.argvs():
        if argv[0] != "cml-edge" or argv[1] in UNPRICED:
            return None
        total += START_S + limits.estimate(_parser().parse_args(argv[1:])).seconds
    return total


@functools.cache
def _parser() -> argparse.ArgumentParser:
    from cml_edge.cli import build_parser

    return build_parser()


def _key(fig: Figure) -> str:
    return f"{fig.command} @ {fig.file}" if fig.file else fig.command


def estimate(figures: list[Figure], rerun: bool = False, echo=_echo) -> float:
    """Print each command's estimate once (the figures sharing it run it once) and the
    total; returns the total seconds of the priced commands."""
    priced, unpriced, seen = 0.0, [], set()
    for fig in figures:
        if fig.kind == "timing" or _key(fig) in seen:
            continue
        seen.add(_key(fig))
        s = seconds(fig, rerun)
        if s is None:
            unpriced.append(fig)
            echo(f"not priced  {fig.where}  {fig.command}")
        elif s > 0:
            priced += s
            echo(f"~{_duration(s):>9}  {fig.where}  {fig.command}")
    read = sum(1 for f in figures if f.kind == "figure" and f.file and not rerun)
    echo(f"{len(seen)} commands, ~{_duration(priced)} on {os.cpu_count()} cores for those "
         f"priced ({read} figures read from committed results files cost nothing"
         + (f"; {len(unpriced)} commands not priced: "
            f"{', '.join(sorted({a[1] for f in unpriced for a in f.argvs() if a[1] in UNPRICED}))}"
            if unpriced else "")
         + "), plus the kernels' first compile (5-10 min, once)")
    return priced


def _duration(s: float) -> str:
    return f"{s:.0f} s" if s < 120 else f"{s / 60:.0f} min" if s < 7200 else f"{s / 3600:.1f} h"


def quick(figures: list[Figure]) -> list[Figure]:
    """The figures read from committed results files and those of the
    :data:`QUICK_COMMANDS` fastest priced commands (the first on the pages of equals)."""
    timed = {}
    for fig in figures:
        s = seconds(fig)
        if fig.kind == "figure" and not fig.file and s is not None:
            timed.setdefault(_key(fig), s)
    fastest = set(sorted(timed, key=timed.get)[:QUICK_COMMANDS])
    return [f for f in figures if f.kind == "figure" and (f.file or _key(f) in fastest)]


def default_pages() -> list[Path]:
    return [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md")),
            ROOT / "benchmarks" / "README.md"]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("pages", nargs="*", type=Path,
                        help="pages to check (default: README.md, docs/**/*.md, "
                             "benchmarks/README.md)")
    parser.add_argument("--list", action="store_true", help="list the figures, run nothing")
    parser.add_argument("--rerun", action="store_true",
                        help="also rerun the figures read from a committed results file")
    parser.add_argument("--grep", default=None, metavar="TEXT",
                        help="only the figures whose command contains TEXT")
    parser.add_argument("--estimate", action="store_true",
                        help="print how long the figures' commands would take, run nothing")
    parser.add_argument("--quick", action="store_true",
                        help="only the figures read from committed results files and those "
                             f"of the {QUICK_COMMANDS} fastest commands")
    parser.add_argument("--timeout", type=float, default=None, metavar="S",
                        help="seconds a command may take (default: no limit)")
    args = parser.parse_args(argv)
    figures: list[Figure] = []
    try:
        for page in args.pages or default_pages():
            figures += parse_page(page)
    except MarkerError as exc:
        print(f"check_figures: {exc}", file=sys.stderr)
        return 2
    if args.grep:
        figures = [f for f in figures if args.grep in f.command]
    if args.quick:
        figures = quick(figures)
    if args.estimate:
        estimate(figures, args.rerun)
        return 0
    if args.list:
        for fig in figures:
            src = f"  @ {fig.file}" if fig.file else ""
            n = sum(len(g) for g in fig.groups)
            print(f"{fig.kind:<7} {fig.where}  {fig.command}{src}" +
                  (f"  ({n} values)" if fig.kind == "figure" else ""))
        return 0
    return 1 if check(figures, args.rerun, args.timeout) else 0


if __name__ == "__main__":
    sys.exit(main())
