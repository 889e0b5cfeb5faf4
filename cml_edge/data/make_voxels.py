"""Generate the small MovingAI-format voxel maps and scenarios shipped in ``data/maps3d``.

    python -m cml_edge.data.make_voxels [--out cml_edge/data/maps3d]

Deterministic (fixed seeds): rerunning rewrites the same files. Each map is 16 x 16 x 16:

- ``floors``: three storeys (floor slabs at z = 5 and z = 10), each split by a wall at
  x = 8 with a 2 x 5 doorway; each slab has a 2 x 2 stairwell, the two at opposite corners,
  so a climb from the ground floor to the top crosses each storey;
- ``shaft``: a hall at the bottom (z < 4) and one at the top (z >= 12) joined only by a
  2 x 2 vertical shaft at the centre; everything else is rock;
- ``pillars``: a forest of vertical pillars, one voxel wide and the full height, on 15 %
  of the (x, y) columns (seed 5).

The scenarios (``NAME.3dscen``) hold 100 problems each, drawn from seed 7 among the pairs
connected under this package's 26 king moves (for ``floors`` and ``shaft``: from below the
first slab or in the bottom hall to above the last slab or in the top hall), with the cost
of a shortest path under those moves (:func:`cml_edge.grid.voxels.voxel_distances`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from cml_edge.grid.voxels import (
    VoxelMap,
    VoxelProblem,
    format_voxel_map,
    format_voxel_scen,
    parse_voxel_map,
    voxel_distances,
)
from cml_edge.io.files import atomic_write_text

SIDE = 16
N_SCEN = 100
SEED = 7


def floors() -> np.ndarray:
    """blocked[x, y, z] of three storeys joined by stairwells at opposite corners."""
    b = np.zeros((SIDE, SIDE, SIDE), dtype=bool)
    for z, (x, y) in ((5, (2, 2)), (10, (12, 12))):
        b[:, :, z] = True
        b[x: x + 2, y: y + 2, z] = False  # the stairwell
    for z0, z1, door in ((0, 5, 3), (6, 10, 10), (11, SIDE, 6)):
        b[8, :, z0:z1] = True  # the wall between the storey's two rooms
        b[8, door: door + 5, z0: z0 + 2] = False  # its doorway, 5 wide, 2 high
    return b


def shaft() -> np.ndarray:
    """blocked[x, y, z]: two halls joined by a 2 x 2 shaft."""
    b = np.ones((SIDE, SIDE, SIDE), dtype=bool)
    b[:, :, :4] = False
    b[:, :, 12:] = False
    b[7:9, 7:9, 4:12] = False
    return b


def pillars(seed: int = 5) -> np.ndarray:
    """blocked[x, y, z]: full-height pillars on 15 % of the columns."""
    rng = np.random.default_rng(seed)
    columns = rng.random((SIDE, SIDE)) < 0.15
    return np.repeat(columns[:, :, None], SIDE, axis=2)


def problems(vmap: VoxelMap, seed: int, start_z=None, goal_z=None) -> list[VoxelProblem]:
    """N_SCEN connected problems; ``start_z`` / ``goal_z``: (z0, z1) ranges, None: any."""
    arena = vmap.arena()
    rng = np.random.default_rng(seed)
    free = np.argwhere(~arena.blocked)

    def pick(zs):
        cand = free if zs is None else free[(free[:, 2] >= zs[0]) & (free[:, 2] < zs[1])]
        return tuple(int(v) for v in cand[rng.integers(len(cand))])

    out: list[VoxelProblem] = []
    cache: dict = {}
    while len(out) < N_SCEN:
        s, g = pick(start_z), pick(goal_z)
        if s == g:
            continue
        if g not in cache:
            cache[g] = voxel_distances(arena, g)
        cost = cache[g][s]
        if np.isfinite(cost):
            out.append(VoxelProblem(s, g, float(cost)))
    return out


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(Path(__file__).parent / "maps3d"))
    args = parser.parse_args(argv)
    out = Path(args.out)
    specs = {"floors": (floors(), (0, 5), (11, SIDE)), "shaft": (shaft(), (0, 4), (12, SIDE)),
             "pillars": (pillars(), None, None)}
    for name, (blocked, start_z, goal_z) in specs.items():
        text = format_voxel_map(blocked)
        vmap = parse_voxel_map(text, f"{name}.3dmap")
        atomic_write_text(out / f"{name}.3dmap", text)
        scen = problems(vmap, SEED, start_z, goal_z)
        atomic_write_text(out / f"{name}.3dscen", format_voxel_scen(f"{name}.3dmap", scen))
        print(f"{name}: {' x '.join(map(str, blocked.shape))}, {int(blocked.sum())} blocked, "
              f"{len(scen)} problems")


if __name__ == "__main__":
    main()
