"""The stationary FPK of the original system in (x, v): conservative finite volumes (docs/fpk2d.md).

Cells of a rectangle [x_lo, x_hi] x [-V, V], v = 0 on a cell face (the friction's jump never
inside a cell). Mass rate of cell c: minus the net flux through its four faces, each flux a
linear combination of cell averages, so the columns of the operator sum to zero (mass is
conserved to round-off) and the stationary law is its null vector:

- x faces, flux v p: p at the face by the third-order upwind-biased value from three cells
  ((-p_{i-1} + 5 p_i + 2 p_{i+1}) / 6 for v > 0; mirrored for v < 0), centred next to the ends;
- v faces, flux a p - B dp/dv: a p the same way by the sign of a at the face, B dp/dv central;
  on the face v = 0 with friction (a jumps by 2 mu there) the flux is exact for the local 1-D
  problem with a piecewise-constant drift (a Scharfetter-Gummel flux of two halves,
  :func:`kink_flux`);
- a wall at x = a (lower; impacts at v < 0): the outflow |v| p(a, v) of each cell at the wall
  (p at the face extrapolated to third order from three cells) is put back into the cells at
  the wall whose velocity interval overlaps the image [e(s0) s0, e(s1) s1] of the cell's speed
  interval, in proportion to the overlap (conservative: the flux balance
  v' p(a, v') dv' = |v| p(a, v) dv, i.e. p(a, e(s) s) = p(a, -s) / (e(s) + s e'(s)) / e(s);
  Newton: p(a, r s) = p(a, -s) / r^2); the upper wall mirrored;
- the cut-off edges (no wall): zero flux.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .physics import Coefficients

#: the declared order of the scheme (second-order finite volumes; the face values are third
#: order, the midpoint coefficients and central diffusion second): tests/test_fpk2d.py fits it
ORDER = 2


@dataclass(frozen=True)
class Grid:
    """Cell edges in x and v (uniform; v = 0 is the edge nv / 2)."""

    xe: np.ndarray
    ve: np.ndarray
    walls: tuple  # the WallMaps inside the box, lower first

    @property
    def x(self) -> np.ndarray:
        return 0.5 * (self.xe[1:] + self.xe[:-1])

    @property
    def v(self) -> np.ndarray:
        return 0.5 * (self.ve[1:] + self.ve[:-1])

    @property
    def hx(self) -> float:
        return float(self.xe[1] - self.xe[0])

    @property
    def hv(self) -> float:
        return float(self.ve[1] - self.ve[0])

    @property
    def shape(self) -> tuple[int, int]:
        return self.xe.size - 1, self.ve.size - 1


def make_grid(x_lo: float, x_hi: float, V: float, nx: int, nv: int, walls: tuple) -> Grid:
    """nx x nv cells on [x_lo, x_hi] x [-V, V]; nv is made even (v = 0 on a face)."""
    nv += nv % 2
    return Grid(np.linspace(x_lo, x_hi, nx + 1), np.linspace(-V, V, nv + 1), walls)


def bernoulli(z: np.ndarray) -> np.ndarray:
    """B(z) = z / (e^z - 1), B(0) = 1, without overflow or cancellation."""
    z = np.asarray(z, dtype=float)
    out = np.empty_like(z)
    small = np.abs(z) < 1e-6
    out[small] = 1.0 - 0.5 * z[small]
    big = ~small
    zb = z[big]
    out[big] = zb / np.expm1(zb)
    return out


def kink_flux(am: np.ndarray, ap: np.ndarray, B: np.ndarray, h: float
              ) -> tuple[np.ndarray, np.ndarray]:
    """(w_left, w_right): the flux J = w_left p_j - w_right p_{j+1} between two centres h
    apart of J = a p - B p' with a = am below the face and ap above it (B constant), exact
    for constant J: each half by Scharfetter-Gummel, the face value eliminated:

        J = (2B/h) [B(-P+) B(-P-) p_j - B(P+) B(P-) p_{j+1}] / (B(P-) + B(-P+)),
        P_(+-) = a_(+-) h / (2B),

    with B(z) = z / (e^z - 1). For am = ap it is the Scharfetter-Gummel flux over h."""
    Pm, Pp = am * h / (2 * B), ap * h / (2 * B)
    bm, bmm = bernoulli(Pm), bernoulli(-Pm)
    bp, bpm = bernoulli(Pp), bernoulli(-Pp)
    den = bm + bpm
    c = 2 * B / h / den
    return c * bpm * bmm, c * bp * bm


class _Triplets:
    def __init__(self) -> None:
        self.r: list[np.ndarray] = []
        self.c: list[np.ndarray] = []
        self.v: list[np.ndarray] = []

    def flux(self, left: np.ndarray, right: np.ndarray, cols: list, weights: list) -> None:
        """A flux from cell ``left`` to cell ``right`` (mass rate, sum_k w_k p[col_k]):
        -flux in left's row, +flux in right's row."""
        for col, w in zip(cols, weights, strict=True):
            w = np.broadcast_to(w, np.shape(left)).ravel()
            col = np.broadcast_to(col, np.shape(left)).ravel()
            self.r += [np.ravel(left), np.ravel(right)]
            self.c += [col, col]
            self.v += [-w, w]

    def matrix(self, n: int) -> sp.csc_matrix:
        keep = [(r, c, v) for r, c, v in zip(self.r, self.c, self.v, strict=True) if r.size]
        r = np.concatenate([k[0] for k in keep])
        c = np.concatenate([k[1] for k in keep])
        v = np.concatenate([k[2] for k in keep])
        ok = r >= 0  # -1: the mass leaves through nothing (never used) or enters from nowhere
        return sp.csc_matrix((v[ok], (r[ok], c[ok])), shape=(n, n))


def operator(c: Coefficients, grid: Grid) -> tuple[sp.csc_matrix, dict]:
    """The sparse operator M (mass rates, M p for cell averages p) and the wall outflow
    stencils (for the impact rates and losses: ``walls[i]`` = (rows, cols, weights, speeds,
    the WallMap))."""
    nx, nv = grid.shape
    hx, hv = grid.hx, grid.hv
    x, v = grid.x, grid.v
    idx = np.arange(nx * nv).reshape(nx, nv)
    T = _Triplets()

    # ---- x faces: flux v p hv between (i, j) and (i + 1, j)
    if nx > 1:
        I, J = np.meshgrid(np.arange(nx - 1), np.arange(nv), indexing="ij")
        vv = v[J]
        pos = vv > 0
        third = np.where(pos, I - 1 >= 0, I + 2 <= nx - 1)
        vel = vv * hv
        L, R = idx[I, J], idx[I + 1, J]
        # centred
        cen = ~third
        T.flux(L[cen], R[cen], [idx[I, J][cen], idx[I + 1, J][cen]],
               [0.5 * vel[cen], 0.5 * vel[cen]])
        m = third & pos
        T.flux(L[m], R[m], [idx[I - 1, J][m], idx[I, J][m], idx[I + 1, J][m]],
               [-vel[m] / 6, 5 * vel[m] / 6, 2 * vel[m] / 6])
        m = third & ~pos
        Ic = np.minimum(I + 2, nx - 1)
        T.flux(L[m], R[m], [idx[I, J][m], idx[I + 1, J][m], idx[Ic, J][m]],
               [2 * vel[m] / 6, 5 * vel[m] / 6, -vel[m] / 6])

    # ---- v faces: flux (a p - B p') hx between (i, j) and (i, j + 1)
    I, J = np.meshgrid(np.arange(nx), np.arange(nv - 1), indexing="ij")
    xf, vf = x[I], grid.ve[J + 1]
    a = c.smooth_drift(xf, vf) - c.mu * np.sign(vf)
    B = c.diffusion(xf, vf)
    L, R = idx[I, J], idx[I, J + 1]
    zero = (J + 1 == nv // 2) & (c.mu > 0)
    # diffusion, central: -B (p_{j+1} - p_j) / hv
    d = B * hx / hv
    nz = ~zero
    T.flux(L[nz], R[nz], [L[nz], R[nz]], [d[nz], -d[nz]])
    ah = a * hx
    pos = a > 0
    third = np.where(pos, J - 1 >= 0, J + 2 <= nv - 1) & nz
    cen = ~third & nz
    T.flux(L[cen], R[cen], [L[cen], R[cen]], [0.5 * ah[cen], 0.5 * ah[cen]])
    m = third & pos
    T.flux(L[m], R[m], [idx[I, J - 1][m], L[m], R[m]],
           [-ah[m] / 6, 5 * ah[m] / 6, 2 * ah[m] / 6])
    m = third & ~pos
    Jc = np.minimum(J + 2, nv - 1)
    T.flux(L[m], R[m], [L[m], R[m], idx[I, Jc][m]],
           [2 * ah[m] / 6, 5 * ah[m] / 6, -ah[m] / 6])
    if zero.any():  # the friction's jump: a = -g - D... +mu below, -mu above
        xs = x[I[zero]]
        a0 = c.smooth_drift(xs, 0.0 * xs)
        wl, wr = kink_flux(a0 + c.mu, a0 - c.mu, c.diffusion(xs, 0.0 * xs), hv)
        T.flux(L[zero], R[zero], [L[zero], R[zero]], [wl * hx, -wr * hx])

    # ---- walls: outflow at the wall face, put back by the impact map
    outflow = []
    for w in grid.walls:
        i0, i1, i2 = (0, 1, 2) if w.side < 0 else (nx - 1, nx - 2, nx - 3)
        src = np.nonzero(v * w.side > 0)[0]            # cells moving into the wall
        s_lo = np.abs(grid.ve[src + (1 if w.side < 0 else 0)])   # speed interval of each
        s_hi = np.abs(grid.ve[src + (0 if w.side < 0 else 1)])
        speed = np.abs(v[src]) * hv                      # |v| dv
        cols = [idx[i0, src], idx[i1, src], idx[i2, src]]
        wts = [11 / 6 * speed, -7 / 6 * speed, 2 / 6 * speed]
        if nx < 3:
            cols, wts = [idx[i0, src]], [speed]
        # the image speed intervals and the target cells (moving away from the wall)
        im_lo, im_hi = w.rebound(s_lo), w.rebound(s_hi)
        if np.any(im_hi < im_lo):
            raise ValueError(f"impact law {w.law!r}: the rebound speed e(s) s is not "
                             "increasing in the impact speed s; the FPK's wall map needs it")
        tgt_edges = np.abs(grid.ve)  # speeds of the target cells' edges
        tgt = np.nonzero(-v * w.side > 0)[0]
        t_lo = np.minimum(tgt_edges[tgt], tgt_edges[tgt + 1])
        t_hi = np.maximum(tgt_edges[tgt], tgt_edges[tgt + 1])
        ov = (np.minimum(im_hi[:, None], t_hi[None, :]) - np.maximum(im_lo[:, None],
                                                                     t_lo[None, :]))
        width = np.maximum(im_hi - im_lo, 1e-300)
        frac = np.maximum(ov, 0.0) / width[:, None]   # (src, tgt)
        srcs, tgts = np.nonzero(frac > 0)
        for col, wt in zip(cols, wts, strict=True):
            # leaves the source cell, enters each target cell by its fraction
            T.flux(idx[i0, src[srcs]], idx[i0, tgt[tgts]], [col[srcs]],
                   [wt[srcs] * frac[srcs, tgts]])
        # mass whose image lies beyond the box's speed range (none in practice) would be
        # lost: put what exceeds V into the fastest target cell
        lost = 1.0 - frac.sum(axis=1)
        far = lost > 1e-12
        if far.any():
            fastest = tgt[np.argmax(t_hi)]
            for col, wt in zip(cols, wts, strict=True):
                T.flux(idx[i0, src[far]], np.full(far.sum(), idx[i0, fastest]), [col[far]],
                       [wt[far] * lost[far]])
        outflow.append({"cols": cols, "weights": [wt / hv for wt in wts],
                        "speed": np.abs(v[src]), "wall": w})
    return T.matrix(nx * nv), {"walls": outflow}
