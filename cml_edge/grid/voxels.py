"""MovingAI voxel maps and scenarios (Brewer & Sturtevant 2018, the 3-D pathfinding
benchmarks): the third dimension's ``.map`` and ``.scen``.

A ``.3dmap`` file is one header line and one voxel per line::

    voxel W H D
    x y z
    ...

``voxel``: the listed voxels are blocked, the rest free; ``rev_voxel``: the listed voxels
are free, the rest blocked (dense maps). Coordinates count from 0, each below its side.

A ``.3dscen`` file is ``version 1`` or ``version 2``, the map's file name, then one
problem per line: start x y z, goal x y z, the optimal cost, then the heuristic ratio
(and, in version 2, a directional ratio): 8 fields, or 9.

Conventions of this package, as for the plane's maps (:mod:`cml_edge.grid.maps`):

- Cubic arenas: the CML lives on an N x N x N grid. A map of W x H x D is placed in the
  cube of N = max(W, H, D), padded with blocked voxels where x >= W, y >= H or z >= D; the
  padding is unreachable, so pairs and metrics are unchanged.
- Moves: the 26 king moves may cut past blocked voxels on an edge or a corner, where the
  benchmark forbids it. A scenario's cost is kept as a record; every metric uses this
  package's BFS step count (:func:`cml_edge.grid.metrics.geodesic_distances`). The
  scenarios shipped in ``cml_edge/data/maps3d`` carry the cost of a shortest path under
  this package's moves (1 a face, sqrt 2 an edge, sqrt 3 a corner:
  :func:`voxel_distances`).
- Step budget: :func:`~cml_edge.grid.maps.step_budget` of the cube's side.
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from cml_edge.grid.arena import GridArena, chebyshev, fewest_moves, move_table
from cml_edge.grid.maps import MapFormatError
from cml_edge.grid.metrics import Pairs, geodesic_distances
from cml_edge.io.reading import MiB, read_text
from cml_edge.sizes import SIZES

VOXEL_SIDE_MAX = 1024
"""The largest side of a voxel map read (the benchmark's largest are a few hundred)."""
VOXEL_MAP_BYTES = 256 * MiB
"""The largest ``.3dmap`` file read: ~20 bytes a listed voxel."""
VOXEL_SCEN_BYTES = 128 * MiB
"""The largest ``.3dscen`` file read: a million problems at ~60 bytes each."""
TYPES = ("voxel", "rev_voxel")


@dataclass(frozen=True)
class VoxelMap:
    """A parsed voxel map: ``blocked`` is bool (W, H, D), indexed [x, y, z]."""

    name: str
    blocked: np.ndarray

    @property
    def side(self) -> int:
        """The side of the cube the map is placed in (padded if not a cube)."""
        return int(max(self.blocked.shape))

    def arena(self, moves: str = "king") -> GridArena:
        """The map as a cubic :class:`GridArena` with the ``moves`` set, padded with blocked
        voxels."""
        n = self.side
        blocked = np.ones((n, n, n), dtype=bool)
        w, h, d = self.blocked.shape
        blocked[:w, :h, :d] = self.blocked
        return GridArena(n, blocked, moves)


@dataclass(frozen=True)
class VoxelProblem:
    """One benchmark problem of a ``.3dscen`` file."""

    start: tuple[int, int, int]
    goal: tuple[int, int, int]
    cost: float


def _ints(parts: list[str], name: str, line: int) -> list[int]:
    try:
        return [int(p) for p in parts]
    except ValueError:
        raise MapFormatError(f"{name} line {line}: a field is not an integer: "
                             f"{' '.join(parts)!r}") from None


def parse_voxel_map(text: str, name: str = "<3dmap>") -> VoxelMap:
    """Parse the text of a ``.3dmap`` file; :class:`~cml_edge.grid.maps.MapFormatError` on
    any malformation."""
    lines = text.splitlines()
    head = lines[0].split() if lines else []
    if len(head) != 4 or head[0] not in TYPES:
        raise MapFormatError(f"{name} line 1: wrong header {(lines[0] if lines else '')!r}; "
                             f"expected 'voxel W H D' or 'rev_voxel W H D'")
    shape = _ints(head[1:], name, 1)
    if min(shape) < 1 or max(shape) > VOXEL_SIDE_MAX or max(shape) < 2:
        raise MapFormatError(f"{name} line 1: sides {' x '.join(head[1:])} are not allowed "
                             f"(allowed: 1..{VOXEL_SIDE_MAX}, the largest at least 2)")
    listed = np.zeros(shape, dtype=bool)
    for i, line in enumerate(lines[1:], start=2):
        parts = line.split()
        if not parts:
            continue
        if len(parts) != 3:
            raise MapFormatError(f"{name} line {i}: {len(parts)} fields, expected 3 (x y z)")
        p = _ints(parts, name, i)
        if not all(0 <= v < s for v, s in zip(p, shape)):
            raise MapFormatError(f"{name} line {i}: voxel {' '.join(parts)} is off the "
                                 f"{' x '.join(map(str, shape))} map")
        listed[tuple(p)] = True
    blocked = listed if head[0] == "voxel" else ~listed
    if blocked.size - int(blocked.sum()) < 2:
        raise MapFormatError(f"{name}: the map has fewer than two free voxels")
    return VoxelMap(name, blocked)


def format_voxel_map(blocked: np.ndarray) -> str:
    """The ``.3dmap`` text of a bool (W, H, D) array: ``voxel``, the blocked voxels in C
    order."""
    w, h, d = blocked.shape
    rows = [f"{x} {y} {z}" for x, y, z in np.argwhere(blocked)]
    return "\n".join([f"voxel {w} {h} {d}", *rows]) + "\n"


def parse_voxel_scen(text: str, name: str = "<3dscen>") -> tuple[str, list[VoxelProblem]]:
    """Parse the text of a ``.3dscen`` file: (the map's file name, its problems)."""
    lines = text.splitlines()
    head = lines[0].split() if lines else []
    if head not in (["version", "1"], ["version", "2"]):
        raise MapFormatError(f"{name} line 1: wrong header {(lines[0] if lines else '')!r}; "
                             f"expected 'version 1' or 'version 2'")
    fields = 8 if head[1] == "1" else 9
    if len(lines) < 2 or len(lines[1].split()) != 1:
        raise MapFormatError(f"{name} line 2: expected the map's file name")
    out = []
    most = SIZES["trials"]
    for i, line in enumerate(lines[2:], start=3):
        parts = line.split()
        if not parts:
            continue
        if len(out) == most.hi:
            raise MapFormatError(f"{name}: more than {most.hi:,.0f} problems (a scenario "
                                 f"file's problems are its trials: {most.why})")
        if len(parts) != fields:
            raise MapFormatError(f"{name} line {i}: {len(parts)} fields, expected {fields} "
                                 f"(start x y z, goal x y z, cost, ratio"
                                 f"{', directional ratio' if fields == 9 else ''})")
        p = _ints(parts[:6], name, i)
        try:
            cost = float(parts[6])
            [float(v) for v in parts[7:]]
        except ValueError:
            raise MapFormatError(f"{name} line {i}: a field is not a number: "
                                 f"{line.strip()!r}") from None
        out.append(VoxelProblem(tuple(p[:3]), tuple(p[3:]), cost))
    if not out:
        raise MapFormatError(f"{name}: no problems after the header")
    return lines[1].strip(), out


def format_voxel_scen(map_name: str, problems: list[VoxelProblem]) -> str:
    """The ``.3dscen`` text (version 1) of ``problems``; the ratio column is the cost over
    the Chebyshev distance (the benchmark's heuristic, octile in three dimensions, is not
    this package's)."""
    lines = ["version 1", map_name]
    for pr in problems:
        ratio = pr.cost / max(1, int(chebyshev(np.array(pr.start), np.array(pr.goal))))
        lines.append(" ".join([*map(str, pr.start), *map(str, pr.goal), f"{pr.cost:.8f}",
                               f"{ratio:.8f}"]))
    return "\n".join(lines) + "\n"


def load_voxel_map(path: str | Path) -> VoxelMap:
    """Read (at most :data:`VOXEL_MAP_BYTES`, a regular file) and parse a ``.3dmap`` file."""
    text = read_text(path, "voxel map file", VOXEL_MAP_BYTES, "ascii", MapFormatError)
    return parse_voxel_map(text, Path(path).name)


def load_voxel_scen(path: str | Path) -> tuple[str, list[VoxelProblem]]:
    """Read (at most :data:`VOXEL_SCEN_BYTES`, a regular file) and parse a ``.3dscen``
    file."""
    text = read_text(path, "voxel scenario file", VOXEL_SCEN_BYTES, "ascii", MapFormatError)
    return parse_voxel_scen(text, Path(path).name)


def voxel_pairs(vmap: VoxelMap, problems: list[VoxelProblem], name: str = "<3dscen>",
                moves: str = "king") -> Pairs:
    """The problems as evaluation :class:`~cml_edge.grid.metrics.Pairs` on
    ``vmap.arena(moves)``: each start and goal a free voxel of the map, the two distinct;
    BFS geodesics under those moves."""
    arena = vmap.arena(moves)
    starts = np.array([pr.start for pr in problems], np.int64).reshape(-1, 3)
    goals = np.array([pr.goal for pr in problems], np.int64).reshape(-1, 3)
    shape = vmap.blocked.shape
    for i, pr in enumerate(problems):
        for what, p in (("start", pr.start), ("goal", pr.goal)):
            if not all(0 <= v < s for v, s in zip(p, shape)):
                raise MapFormatError(f"{name}: problem {i + 1}: {what} {p} is off the "
                                     f"{' x '.join(map(str, shape))} map")
            if not arena.is_free(p):
                raise MapFormatError(f"{name}: problem {i + 1}: {what} {p} is a blocked voxel")
        if pr.start == pr.goal:
            raise MapFormatError(f"{name}: problem {i + 1} starts at its goal {pr.goal}")
    return Pairs(starts, goals, fewest_moves(starts, goals, moves),
                 geodesic_distances(arena, starts, goals))


def voxel_distances(arena: GridArena, source: tuple[int, int, int]) -> np.ndarray:
    """Shortest-path costs from ``source`` under the 26 king moves (1 a face, sqrt 2 an
    edge, sqrt 3 a corner; Dijkstra); inf where unreachable."""
    table = [tuple(int(v) for v in m) for m in move_table(3, "king")]
    cost = [float(np.sqrt(sum(abs(v) for v in m))) for m in table]
    free = ~arena.blocked
    n = arena.size
    dist = np.full(arena.blocked.shape, np.inf)
    dist[tuple(source)] = 0.0
    heap = [(0.0, tuple(source))]
    while heap:
        d, (x, y, z) = heapq.heappop(heap)
        if d > dist[x, y, z]:
            continue
        for (dx, dy, dz), c in zip(table, cost):
            q = (x + dx, y + dy, z + dz)
            if 0 <= q[0] < n and 0 <= q[1] < n and 0 <= q[2] < n and free[q] \
                    and d + c < dist[q] - 1e-12:
                dist[q] = d + c
                heapq.heappush(heap, (d + c, q))
    return dist


# maps shipped with the package ------------------------------------------------------
def shipped_voxel_maps() -> list[str]:
    """Names (without ``.3dmap``) of the voxel maps shipped in ``cml_edge/data/maps3d``."""
    folder = resources.files("cml_edge") / "data" / "maps3d"
    return sorted(p.name[:-6] for p in folder.iterdir() if p.name.endswith(".3dmap"))


def shipped_voxel_path(name: str, suffix: str = ".3dmap") -> Path:
    """The file of a shipped voxel map (``suffix`` ``.3dmap``) or its problems
    (``.3dscen``)."""
    path = Path(str(resources.files("cml_edge") / "data" / "maps3d" / f"{name}{suffix}"))
    if not path.is_file():
        raise MapFormatError(f"no shipped voxel map {name!r}; shipped: "
                             f"{', '.join(shipped_voxel_maps())}")
    return path


def resolve_voxel_map(spec: str) -> Path:
    """A voxel map file path, or the name of a shipped voxel map (``floors``, ...)."""
    p = Path(spec)
    if p.is_file() or p.suffix == ".3dmap" or "/" in spec:
        return p
    return shipped_voxel_path(spec)
