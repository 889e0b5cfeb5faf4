"""Generate the small MovingAI-format maps and scenarios shipped in ``data/maps``.

    python -m cml_edge.data.make_maps [--out cml_edge/data/maps]

Deterministic (fixed seeds): rerunning rewrites the same files. Each map is 32 x 32:

- ``rooms``: a 3 x 3 grid of rooms with 1-cell walls and one 2-cell door in each wall
  between neighbouring rooms; most pairs lie in different rooms, where a greedy local
  planner stalls in the corner nearest the goal;
- ``utrap``: an empty map with a U-shaped wall opening west; the scenarios start inside
  the U with the goal east of it (the classic trap of local planners);
- ``maze``: a corridor maze (recursive backtracker on a 10 x 10 grid of 2-cell-wide
  corridors, 1-cell walls).

The scenarios (``NAME.map.scen``) hold 100 problems each, drawn from seed 7 among the
pairs connected under this package's king moves, with the octile length of a shortest
path under those moves (:func:`cml_edge.grid.maps.octile_distances`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from cml_edge.grid.maps import GridMap, format_map, format_scen, octile_distances, parse_map
from cml_edge.io.files import atomic_write_text

SIDE = 32
N_SCEN = 100
SEED = 7


def rooms(seed: int = 1) -> np.ndarray:
    """blocked[y, x] of a 3 x 3 grid of rooms with 2-cell doors."""
    rng = np.random.default_rng(seed)
    b = np.zeros((SIDE, SIDE), dtype=bool)
    walls = (10, 21)
    bounds = [(0, 10), (11, 21), (22, SIDE)]
    for w in walls:
        b[w, :] = True  # horizontal wall at row w
        b[:, w] = True  # vertical wall at column w
    for w in walls:
        for lo, hi in bounds:  # one door per wall segment between two rooms
            d = int(rng.integers(lo + 1, hi - 2))
            b[w, d: d + 2] = False
            d = int(rng.integers(lo + 1, hi - 2))
            b[d: d + 2, w] = False
    return b


def utrap() -> np.ndarray:
    """blocked[y, x]: a U of 1-cell walls, bottom at column 20, arms along rows 8 and 23."""
    b = np.zeros((SIDE, SIDE), dtype=bool)
    b[8:24, 20] = True
    b[8, 9:21] = True
    b[23, 9:21] = True
    return b


def maze(seed: int = 3) -> np.ndarray:
    """blocked[y, x]: a recursive-backtracker maze of 2-wide corridors and 1-wide walls."""
    rng = np.random.default_rng(seed)
    cells = 10
    b = np.ones((SIDE, SIDE), dtype=bool)

    def carve(cx: int, cy: int) -> None:
        b[3 * cy + 1: 3 * cy + 3, 3 * cx + 1: 3 * cx + 3] = False

    seen = np.zeros((cells, cells), dtype=bool)
    stack = [(0, 0)]
    seen[0, 0] = True
    carve(0, 0)
    while stack:
        cx, cy = stack[-1]
        nbrs = [(cx + dx, cy + dy) for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1))
                if 0 <= cx + dx < cells and 0 <= cy + dy < cells and not seen[cy + dy, cx + dx]]
        if not nbrs:
            stack.pop()
            continue
        nx, ny = nbrs[int(rng.integers(len(nbrs)))]
        seen[ny, nx] = True
        carve(nx, ny)
        # open the wall between the two cells (2 cells wide)
        if nx != cx:
            wx = 3 * max(cx, nx)
            b[3 * cy + 1: 3 * cy + 3, wx] = False
        else:
            wy = 3 * max(cy, ny)
            b[wy, 3 * cx + 1: 3 * cx + 3] = False
        stack.append((nx, ny))
    return b


def scenarios(grid: GridMap, seed: int, start_box=None, goal_box=None):
    """N_SCEN connected (start, goal, octile length) problems; boxes are (x0, x1, y0, y1)."""
    arena = grid.arena()
    rng = np.random.default_rng(seed)
    free = np.argwhere(~arena.blocked)  # (x, y)

    def pick(box):
        cand = free if box is None else free[(free[:, 0] >= box[0]) & (free[:, 0] < box[1])
                                             & (free[:, 1] >= box[2]) & (free[:, 1] < box[3])]
        return tuple(int(v) for v in cand[rng.integers(len(cand))])

    out = []
    cache: dict = {}
    while len(out) < N_SCEN:
        s, g = pick(start_box), pick(goal_box)
        if s == g:
            continue
        if g not in cache:
            cache[g] = octile_distances(arena, g)
        length = cache[g][s]
        if np.isfinite(length):
            out.append((s, g, float(length)))
    return out


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(Path(__file__).parent / "maps"))
    args = parser.parse_args(argv)
    out = Path(args.out)
    specs = {
        "rooms": (rooms(), None, None),
        "utrap": (utrap(), (11, 20, 10, 23), (23, SIDE, 4, 28)),
        "maze": (maze(), None, None),
    }
    for name, (blocked, sbox, gbox) in specs.items():
        text = format_map(blocked)
        grid = parse_map(text, f"{name}.map")
        atomic_write_text(out / f"{name}.map", text)
        scen = scenarios(grid, SEED, sbox, gbox)
        atomic_write_text(out / f"{name}.map.scen", format_scen(f"{name}.map", grid, scen))
        print(f"{name}: {grid.width} x {grid.height}, {int(blocked.sum())} blocked, "
              f"{len(scen)} scenarios")


if __name__ == "__main__":
    main()
