"""Where the next points of an adaptive sweep go: refinement of a validity boundary.

An adaptive sweep (``mode = "adaptive"``, harness/sweeps/spec.py, docs/maps.md) varies one or two
parameters over ranges; each range is mapped to [0, 1] (``u = (value - start) / (stop - start)``)
so that both directions weigh alike. What is refined is the model's verdict within the Monte
Carlo noise, through

    f = log( L1 / (2 L1_floor) )        (f < 0: within the noise, the check's verdict)

whose sign is the verdict and whose differences are relative changes of the error.

The design starts with an n0 x n0 lattice (n0 x 1 in one dimension; n0 = sqrt(budget / 4)
clipped to 3..9, so about a quarter of the budget), then adds points in batches. The finished
points are triangulated (Delaunay, scipy; intervals in one dimension) and every triangle gets

    loss = sqrt(area) x (1 + spread of f over its vertices) x (1 + BOUNDARY_WEIGHT [f changes sign])

(0 for a triangle already finer than the resolution: longest edge <= sqrt(2) / (resolution - 1),
the diagonal of a cell of a resolution x resolution grid). A batch takes the triangles of
largest loss, one point each: the centre of the triangle, or the middle of its longest edge
when the triangle is thin (longest edge^2 / area > 5 / (sqrt(3)/4), as python-adaptive's
Learner2D), rounded to multiples of 2^-20 of the range; a point that is already there (or
already in the batch) passes the turn to the next triangle. So points go first where the verdict
changes between neighbours, then where the error changes fastest, and the big empty triangles
are split as they wait.

Everything here is a pure function of the finished points and their values, in the order they
were added: the same sweep file and seed give the same points on any executor, and a sweep
started again replays the same batches from the records on disk (ties are broken by the
triangulation's order, itself a function of the input order).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

BOUNDARY_WEIGHT = 8.0  # a triangle across the verdict's boundary counts 9x one without
THIN = 5.0  # badness above which the longest edge is split (python-adaptive's max_badness)
QUANTUM = 2.0**-20  # unit coordinates are multiples of this (exact binary fractions)
N0_RANGE = (3, 9)

Unit = tuple[float, ...]


def initial_design(dims: int, budget: int) -> list[Unit]:
    """The first points: an n0^dims lattice of the unit cube (n0 from the budget, see module),
    in lexicographic order."""
    n0 = int(min(max(round(math.sqrt(budget / 4.0)), N0_RANGE[0]), N0_RANGE[1]))
    if dims == 1:
        n0 = min(max(budget // 4, N0_RANGE[0]), 3 * N0_RANGE[1])
    axis = [_quantise(i / (n0 - 1)) for i in range(n0)]
    if dims == 1:
        return [(u,) for u in axis]
    return [(a, b) for a in axis for b in axis]


def log_ratio(l1: float | None, floor: float | None) -> float:
    """f = log(L1 / (2 floor)): negative within the noise; NaN without numbers."""
    if l1 is None or floor is None or not (math.isfinite(l1) and math.isfinite(floor)) \
            or floor <= 0:
        return math.nan
    return math.log(max(l1, 1e-300) / (2.0 * floor))


def _quantise(u: float) -> float:
    return min(max(round(u / QUANTUM) * QUANTUM, 0.0), 1.0)


def min_edge(resolution: int) -> float:
    """Longest edge (unit coordinates) below which a triangle is not split."""
    return math.sqrt(2.0) / (resolution - 1)


def _factor(values: np.ndarray) -> np.ndarray:
    """(1 + spread) (1 + BOUNDARY_WEIGHT [sign change]) per row of vertex values; a row with
    a NaN (a failed point) counts as flat."""
    with np.errstate(invalid="ignore"):
        lo, hi = np.min(values, axis=1), np.max(values, axis=1)
    ok = np.isfinite(lo) & np.isfinite(hi)
    spread = np.where(ok, hi - lo, 0.0)
    change = ok & (lo < 0.0) & (hi >= 0.0)
    return (1.0 + spread) * (1.0 + BOUNDARY_WEIGHT * change)


def losses(points: Sequence[Unit], values: Sequence[float], resolution: int
           ) -> tuple[np.ndarray, list[Unit]]:
    """(loss, candidate point) of every triangle (interval in one dimension)."""
    pts = np.asarray(points, dtype=float)
    f = np.asarray(values, dtype=float)
    edge_min = min_edge(resolution)
    if pts.shape[1] == 1:
        order = np.argsort(pts[:, 0], kind="stable")
        x, fv = pts[order, 0], f[order]
        length = np.diff(x)
        loss = length * _factor(np.stack([fv[:-1], fv[1:]], axis=1))
        loss[length <= edge_min / math.sqrt(2.0)] = 0.0
        cands = [(_quantise(0.5 * (a + b)),) for a, b in zip(x[:-1], x[1:], strict=True)]
        return loss, cands
    from scipy.spatial import Delaunay

    tri = Delaunay(pts)
    simplices = tri.simplices
    corners = pts[simplices]  # (T, 3, 2)
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    cross = (b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]
    area = 0.5 * np.abs(cross)
    rolled = np.roll(corners, 1, axis=1)
    edges = np.linalg.norm(corners - rolled, axis=2)  # edge i joins vertex i-1 and i
    longest = np.argmax(edges, axis=1)
    e_max = edges[np.arange(len(edges)), longest]
    loss = np.sqrt(area) * _factor(f[simplices])
    loss[(e_max <= edge_min) | (area <= 0)] = 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        badness = e_max**2 / area * (math.sqrt(3.0) / 4.0)
    cands = []
    for t in range(len(simplices)):
        if badness[t] > THIN:
            i = longest[t]
            p = 0.5 * (corners[t, i] + rolled[t, i])
        else:
            p = corners[t].mean(axis=0)
        cands.append((_quantise(float(p[0])), _quantise(float(p[1]))))
    return loss, cands


def next_batch(points: Sequence[Unit], values: Sequence[float], size: int, *,
               resolution: int) -> list[Unit]:
    """Up to ``size`` new points (unit coordinates) from the finished ``points`` and their
    ``values`` (f, NaN for a failed point); fewer (or none) when the triangles left to split
    are all finer than the resolution."""
    loss, cands = losses(points, values, resolution)
    have = set(points)
    out: list[Unit] = []
    for t in np.argsort(-loss, kind="stable"):
        if len(out) >= size or loss[t] <= 0.0:
            break
        p = cands[t]
        if p in have:
            continue
        have.add(p)
        out.append(p)
    return out
