"""MovingAI grid maps and scenarios (Sturtevant 2012, the grid-pathfinding benchmarks).

A ``.map`` file is a four-line header and the rows::

    type octile
    height H
    width W
    map
    <H rows of W characters>

``.`` and ``G`` are free ground; ``@``, ``O``, ``T`` and ``W`` are blocked (out of
bounds, trees, water: all impassable for this agent); ``S`` (swamp) is passable in the
benchmark's convention and is read as free. Any other character is an error.

A ``.scen`` file is ``version 1`` (or ``version 1.0``) and then one line per problem,
tab- or space-separated: bucket, map, map width, map height, start x, start y, goal x,
goal y, optimal length.

Conventions of this package:

- Coordinates: x is the column and y the row of the file (row 0 first), as in the
  benchmark; a :class:`~cml_edge.grid.arena.GridArena` is indexed ``[x, y]``, so
  ``blocked[x, y]`` is the character at row y, column x.
- Square arenas: the CML lives on an N x N grid. A map of H != W is padded to
  N = max(H, W) with blocked cells on the right (columns W..N-1) or at the bottom
  (rows H..N-1); the padding is unreachable, so pairs and metrics are unchanged.
- Moves: the agent's 8 king moves may cut a corner between two blocked cells (as in
  :mod:`cml_edge.grid.arena`), where the benchmark forbids it. The ``optimal length`` column
  of a scenario is therefore kept only as a record; every metric uses this package's
  BFS step count (:func:`cml_edge.grid.metrics.geodesic_distances`). The scenarios shipped
  in ``cml_edge/data/maps`` carry the octile length of a shortest path under this
  package's moves.
- Step budget on a map: :func:`step_budget` (the paper's 100 actions per 30 cells of
  side, and never fewer than 100).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from cml_edge.errors import InputError
from cml_edge.grid.arena import GridArena, fewest_moves
from cml_edge.grid.metrics import Pairs, geodesic_distances
from cml_edge.io.reading import MiB, read_text
from cml_edge.sizes import SIZES

FREE_CHARS = frozenset(".GS")
BLOCKED_CHARS = frozenset("@OTW")
PAPER_BUDGET = 100
PAPER_SIDE = 30


class MapFormatError(InputError):
    """A malformed .map or .scen file (the message is one line naming what is wrong)."""


@dataclass(frozen=True)
class GridMap:
    """A parsed map: ``blocked`` is bool (height, width), indexed [row y, column x]."""

    name: str
    blocked: np.ndarray

    @property
    def height(self) -> int:
        return int(self.blocked.shape[0])

    @property
    def width(self) -> int:
        return int(self.blocked.shape[1])

    @property
    def side(self) -> int:
        """The side of the square arena the map is placed in (padded if not square)."""
        return max(self.height, self.width)

    def arena(self, moves: str = "king") -> GridArena:
        """The map as a square :class:`GridArena` indexed [x, y] with the ``moves`` set,
        padded with blocked cells."""
        n = self.side
        blocked = np.ones((n, n), dtype=bool)
        blocked[: self.width, : self.height] = self.blocked.T
        return GridArena(n, blocked, moves)


@dataclass(frozen=True)
class Scenario:
    """One benchmark problem of a ``.scen`` file."""

    bucket: int
    map_name: str
    width: int
    height: int
    start: tuple[int, int]
    goal: tuple[int, int]
    optimal_length: float


def step_budget(side: int) -> int:
    """Planning step budget on an N x N arena: max(100, ceil(100 N / 30)).

    The paper's 100 actions on its 30 x 30 arena, scaled with the side (the longest
    Chebyshev distance) for larger arenas: 200 on 60 x 60, 400 on 120 x 120.
    """
    return max(PAPER_BUDGET, math.ceil(PAPER_BUDGET * side / PAPER_SIDE))


def parse_map(text: str, name: str = "<map>") -> GridMap:
    """Parse the text of a ``.map`` file; :class:`MapFormatError` on any malformation."""
    lines = text.splitlines()
    while lines and not lines[-1].strip():
        lines.pop()
    expected = ("type", "height", "width", "map")
    header: dict[str, str] = {}
    for i, key in enumerate(expected):
        if i >= len(lines):
            raise MapFormatError(f"{name}: the header ends at line {i + 1}; expected "
                                 f"'type octile', 'height H', 'width W', 'map'")
        parts = lines[i].split()
        if not parts or parts[0].lower() != key or (key == "map") != (len(parts) == 1) \
                or len(parts) > 2:
            want = {"type": "type octile", "height": "height H", "width": "width W",
                    "map": "map"}[key]
            raise MapFormatError(f"{name} line {i + 1}: wrong header {lines[i].strip()!r}; "
                                 f"expected {want!r}")
        header[key] = parts[1] if len(parts) == 2 else ""
    if header["type"] != "octile":
        raise MapFormatError(f"{name} line 1: map type {header['type']!r} is not supported "
                             f"(allowed: octile)")
    dims = {}
    for key in ("height", "width"):
        try:
            dims[key] = int(header[key])
        except ValueError:
            dims[key] = 0
        if dims[key] < 1:
            raise MapFormatError(f"{name}: {key} {header[key]!r} is not a positive integer")
    h, w = dims["height"], dims["width"]
    rows = [line.rstrip("\r") for line in lines[4:]]
    if len(rows) != h:
        raise MapFormatError(f"{name}: the header says height {h} but the map has "
                             f"{len(rows)} rows")
    blocked = np.zeros((h, w), dtype=bool)
    for y, row in enumerate(rows):
        if len(row) != w:
            raise MapFormatError(f"{name} line {y + 5}: ragged row of {len(row)} characters "
                                 f"(width is {w})")
        for x, ch in enumerate(row):
            if ch in BLOCKED_CHARS:
                blocked[y, x] = True
            elif ch not in FREE_CHARS:
                raise MapFormatError(f"{name} line {y + 5}: unknown character {ch!r} at "
                                     f"column {x} (allowed: . G S free, @ O T W blocked)")
    if h * w - int(blocked.sum()) < 2:
        raise MapFormatError(f"{name}: the map has fewer than two free cells")
    if max(h, w) < 2:
        raise MapFormatError(f"{name}: the map is smaller than 2 x 2")
    return GridMap(name, blocked)


MAP_BYTES = 4 * MiB
"""The largest ``.map`` file read: a map of the largest side, 1,024, is ~1 MiB."""
SCEN_BYTES = 128 * MiB
"""The largest ``.scen`` file read: its documented 1,000,000 problems at ~60 bytes each."""


def load_map(path: str | Path) -> GridMap:
    """Read (at most :data:`MAP_BYTES`, a regular file) and parse a ``.map`` file."""
    text = read_text(path, "map file", MAP_BYTES, "ascii", MapFormatError)
    return parse_map(text, Path(path).name)


def format_map(blocked_yx: np.ndarray) -> str:
    """The ``.map`` text of a bool (height, width) array (``@`` blocked, ``.`` free)."""
    h, w = blocked_yx.shape
    rows = ["".join("@" if b else "." for b in row) for row in blocked_yx]
    return "\n".join(["type octile", f"height {h}", f"width {w}", "map", *rows]) + "\n"


def parse_scen(text: str, name: str = "<scen>") -> list[Scenario]:
    """Parse the text of a ``.scen`` file; :class:`MapFormatError` on any malformation."""
    lines = text.splitlines()
    if not lines or lines[0].split() not in (["version", "1"], ["version", "1.0"]):
        first = lines[0].strip() if lines else ""
        raise MapFormatError(f"{name} line 1: wrong header {first!r}; expected 'version 1'")
    out = []
    most = SIZES["trials"]
    for i, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        if len(out) == most.hi:
            raise MapFormatError(f"{name}: more than {most.hi:,.0f} problems (a scenario file's "
                                 f"problems are its trials: {most.why})")
        parts = line.split("\t") if "\t" in line else line.split()
        parts = [p.strip() for p in parts]
        if len(parts) != 9:
            raise MapFormatError(f"{name} line {i}: {len(parts)} fields, expected 9 (bucket, "
                                 f"map, width, height, start x, start y, goal x, goal y, "
                                 f"optimal length)")
        try:
            ints = [int(p) for p in (parts[0], *parts[2:8])]
            optimal = float(parts[8])
        except ValueError:
            raise MapFormatError(f"{name} line {i}: a field is not a number: "
                                 f"{line.strip()!r}") from None
        bucket, width, height, sx, sy, gx, gy = ints
        out.append(Scenario(bucket, parts[1], width, height, (sx, sy), (gx, gy), optimal))
    if not out:
        raise MapFormatError(f"{name}: no scenarios after the header")
    return out


def load_scen(path: str | Path) -> list[Scenario]:
    """Read (at most :data:`SCEN_BYTES`, a regular file) and parse a ``.scen`` file."""
    text = read_text(path, "scenario file", SCEN_BYTES, "ascii", MapFormatError)
    return parse_scen(text, Path(path).name)


def format_scen(map_name: str, grid: GridMap, pairs: list[tuple[tuple[int, int],
                tuple[int, int], float]]) -> str:
    """The ``.scen`` text of ``(start, goal, optimal length)`` triples (bucket = length // 4)."""
    lines = ["version 1"]
    for (sx, sy), (gx, gy), length in pairs:
        lines.append("\t".join(str(v) for v in (int(length // 4), map_name, grid.width,
                                                  grid.height, sx, sy, gx, gy,
                                                  f"{length:.8f}")))
    return "\n".join(lines) + "\n"


def scenario_pairs(grid: GridMap, scenarios: list[Scenario], name: str = "<scen>",
                   moves: str = "king") -> Pairs:
    """The scenarios as evaluation :class:`~cml_edge.grid.metrics.Pairs` on
    ``grid.arena(moves)``.

    Each problem must fit the map (its width and height agree, start and goal are free
    cells, and differ); BFS geodesics use those moves.
    """
    arena = grid.arena(moves)
    starts = np.zeros((len(scenarios), 2), np.int64)
    goals = np.zeros((len(scenarios), 2), np.int64)
    for i, sc in enumerate(scenarios):
        if (sc.width, sc.height) != (grid.width, grid.height):
            raise MapFormatError(f"{name}: problem {i + 1} is for a {sc.width} x {sc.height} "
                                 f"map, the map is {grid.width} x {grid.height}")
        for what, p in (("start", sc.start), ("goal", sc.goal)):
            if not (0 <= p[0] < grid.width and 0 <= p[1] < grid.height):
                raise MapFormatError(f"{name}: problem {i + 1}: {what} {p[0]} {p[1]} is off "
                                     f"the {grid.width} x {grid.height} map")
            if not arena.is_free(p):
                raise MapFormatError(f"{name}: problem {i + 1}: {what} {p[0]} {p[1]} is on a "
                                     f"blocked cell")
        if sc.start == sc.goal:  # no path to measure: its overhead would be 0 / 0
            raise MapFormatError(f"{name}: problem {i + 1} starts at its goal "
                                 f"{sc.goal[0]} {sc.goal[1]}")
        starts[i], goals[i] = sc.start, sc.goal
    return Pairs(starts, goals, fewest_moves(starts, goals, moves),
                 geodesic_distances(arena, starts, goals))


def octile_distances(arena: GridArena, source: tuple[int, int]) -> np.ndarray:
    """Octile (cardinal 1, diagonal sqrt 2) shortest-path lengths under this package's moves."""
    import heapq

    from cml_edge.grid.arena import MOVES

    n = arena.size
    dist = np.full((n, n), np.inf)
    dist[source] = 0.0
    heap = [(0.0, source)]
    while heap:
        d, (x, y) = heapq.heappop(heap)
        if d > dist[x, y]:
            continue
        for dx, dy in MOVES:
            nx, ny = x + int(dx), y + int(dy)
            if arena.is_free((nx, ny)):
                nd = d + (math.sqrt(2.0) if dx and dy else 1.0)
                if nd < dist[nx, ny] - 1e-12:
                    dist[nx, ny] = nd
                    heapq.heappush(heap, (nd, (nx, ny)))
    return dist


# maps shipped with the package ------------------------------------------------------
def shipped_maps() -> list[str]:
    """Names (without ``.map``) of the maps shipped in ``cml_edge/data/maps``."""
    folder = resources.files("cml_edge") / "data" / "maps"
    return sorted(p.name[:-4] for p in folder.iterdir() if p.name.endswith(".map"))


def shipped_path(name: str, suffix: str = ".map") -> Path:
    """The file of a shipped map (``suffix`` ``.map``) or its scenarios (``.map.scen``)."""
    path = Path(str(resources.files("cml_edge") / "data" / "maps" / f"{name}{suffix}"))
    if not path.is_file():
        raise MapFormatError(f"no shipped map {name!r}; shipped: {', '.join(shipped_maps())}")
    return path


def resolve_map(spec: str) -> Path:
    """A map file path, or the name of a shipped map (``rooms``, ``utrap``, ...)."""
    p = Path(spec)
    if p.is_file() or p.suffix == ".map" or "/" in spec:
        return p
    return shipped_path(spec)
