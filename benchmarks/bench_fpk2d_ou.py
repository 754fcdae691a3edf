"""Issue 46 item 4: is the original system's FPK worth shipping for OU noise? A measurement.

With OU noise xi' = -alpha1 xi + W (E[W W] = 2 D delta) the original system's FPK is 3-D in
(x, v, xi) and has no diffusion in v. A Hermite expansion in eta = xi / sigma
(sigma^2 = D / alpha1, the OU's stationary variance; Risken 1989, sec. 10.4: the OU operator is
diagonal on phi(eta) He_n(eta), eigenvalue -n alpha1, and eta He_n = He_{n+1} + n He_{n-1}),
with p = phi(eta) sum_n d_n(x, v) He_n(eta) / sqrt(n!), turns it into n_h coupled 2-D transport
equations:

    0 = -v d_x d_n - d_v(a d_n) - n alpha1 d_n - f sigma d_v(sqrt(n) d_{n-1} + sqrt(n+1) d_{n+1}),

d_0 = p(x, v). The walls act on each mode alike (xi is unchanged by an impact): fpk2d's
operator with B = 0 gives each block; the coupling is a conservative central flux in v. The
system is solved (a) by one sparse LU (SuperLU) and (b) by GMRES with an incomplete-LU
preconditioner, both with the pinned cell of mode 0. Coulomb friction's sticking (an atom on
v = 0 where |g - f xi| < mu: there is no diffusion in v to smooth it) is not represented: the
scene is paper-base with mu = 0, and its Monte Carlo (same scene) is run beside.

    python benchmarks/bench_fpk2d_ou.py [--quick]

Writes benchmarks/results/fpk2d_ou.json: per grid (n x n cells, n_h modes) the CPU seconds,
peak memory of the LU's factors, GMRES iterations, and the L1 of p(A) against the finest grid
and against the Monte Carlo (with its floor and CPU seconds).
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path
from types import SimpleNamespace as NS

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import LinearOperator, gmres, spilu, splu
from vifpk.fpk2d.observables import marginals
from vifpk.fpk2d.physics import Coefficients, coefficients
from vifpk.fpk2d.scheme import make_grid, operator
from vifpk.fpk2d.solve import box

from vifpk.core.walls import Wall

ROOT = Path(__file__).resolve().parents[1]
D, ALPHA1, R = 0.01, 2.0, 0.96
SIGMA = math.sqrt(D / ALPHA1)


def base_coefficients() -> Coefficients:
    white = coefficients(NS(restoring_law=(1.0, 0.6), damping_law=(-0.025, 0.05),
                            velocity_law=(), mu=0.0, f=1.0,
                            walls=(Wall(side="lower", at=0.0, r=R),)),
                         NS(kind="white", D=D))
    return Coefficients(k=white.k, d=white.d, e=white.e, mu=0.0, B0=0.0, Dk=0.0, Dc=0.0,
                        walls=white.walls)


def coupling(grid) -> sp.csr_matrix:
    """Mass rates of -f sigma d_v(q) for cell averages q: central face values, zero flux at
    +-V (conservative)."""
    nx, nv = grid.shape
    idx = np.arange(nx * nv).reshape(nx, nv)
    L, R_ = idx[:, :-1].ravel(), idx[:, 1:].ravel()
    w = 0.5 * SIGMA * grid.hx  # f = 1
    rows = np.concatenate([L, L, R_, R_])
    cols = np.concatenate([L, R_, L, R_])
    vals = np.concatenate([-w * np.ones(L.size), -w * np.ones(L.size),
                           w * np.ones(L.size), w * np.ones(L.size)])
    return sp.csr_matrix((vals, (rows, cols)), shape=(nx * nv, nx * nv))


def system(c: Coefficients, E_max: float, n: int, nh: int):
    lo, hi, V, walls = box(c, E_max)
    grid = make_grid(lo, hi, V, n, n, walls)
    M, _ = operator(c, grid)
    G = coupling(grid)
    N = M.shape[0]
    eye = sp.identity(N, format="csr") * grid.hx * grid.hv
    blocks = [[None] * nh for _ in range(nh)]
    for k in range(nh):
        blocks[k][k] = M - k * ALPHA1 * eye
        if k > 0:
            blocks[k][k - 1] = math.sqrt(k) * G
        if k + 1 < nh:
            blocks[k][k + 1] = math.sqrt(k + 1) * G
    A = sp.bmat(blocks, format="csr")
    # pin mode 0 at the densest cell of the white-noise law's neighbourhood: x ~ 0.8, v ~ 0
    i = int(np.searchsorted(grid.xe, 0.5 * (lo + hi)) - 1)
    pin = i * grid.shape[1] + grid.shape[1] // 2
    keep = np.ones(A.shape[0])
    keep[pin] = 0.0
    A = sp.diags(keep) @ A + sp.csr_matrix(([1.0], ([pin], [pin])), shape=A.shape)
    rhs = np.zeros(A.shape[0])
    rhs[pin] = 1.0
    return grid, A.tocsc(), rhs, N


def density_A(c, grid, d0, A):
    p = d0.reshape(grid.shape)
    p = p / (p.sum() * grid.hx * grid.hv)
    return marginals(c, grid, p, A)["data"]["A"]


def run(n: int, nh: int, method: str, c, E_max, A) -> dict:
    import resource

    t0 = time.process_time()
    grid, M, rhs, N = system(c, E_max, n, nh)
    rec: dict = {"cells": n, "modes": nh, "unknowns": int(M.shape[0]), "method": method}
    if method == "lu":
        lu = splu(M, permc_spec="COLAMD")
        sol = lu.solve(rhs)
        rec["factor_nnz"] = int(lu.L.nnz + lu.U.nnz)
        rec["factor_MB"] = rec["factor_nnz"] * 12 / 1e6
    else:
        ilu = spilu(M, drop_tol=1e-4, fill_factor=20)
        pre = LinearOperator(M.shape, ilu.solve)
        it = [0]

        def count(_):
            it[0] += 1

        sol, info = gmres(M, rhs, M=pre, rtol=1e-10, restart=100, maxiter=20,
                          callback=count, callback_type="pr_norm")
        rec["gmres_info"] = int(info)
        rec["iterations"] = it[0]
        rec["residual"] = float(np.linalg.norm(M @ sol - rhs) / np.linalg.norm(rhs))
    rec["seconds"] = time.process_time() - t0
    rec["maxrss_MB"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e3
    d0 = sol[:N]
    rec["negative_fraction"] = float(-np.minimum(d0, 0).sum() / np.abs(d0).sum())
    rec["pA"] = density_A(c, grid, d0, A)["p"].tolist()
    return rec


def monte_carlo(A_edges: np.ndarray, floor: float) -> dict:
    import vifpk

    t0 = time.process_time()
    res = vifpk.solve("paper-base", "montecarlo", set=["system.mu=0.0"], floor=floor,
                      budget=900)
    return {"seconds_cpu": time.process_time() - t0, "data": res.data["A"],
            "floor": res.info["L1_floor"]["A"]}


def main() -> None:
    quick = "--quick" in sys.argv
    c = base_coefficients()
    E_max = 3.0  # U(A) at A = 1.8: the base scene's p(A) is ~1e-9 there (docs/averaging.md)
    A = np.linspace(0.0, float(c.amplitude(np.array([E_max]))[0]), 801)
    # the LU's factors grow ~ n^3 (48^2 x 8 modes: 244 MB): larger grids by GMRES + ILU only
    grids = [(32, 8, "lu"), (48, 8, "lu"), (48, 8, "gmres"), (64, 12, "gmres")]
    if not quick:
        grids += [(96, 12, "gmres"), (128, 16, "gmres")]
    out = []
    for n, nh, method in grids:
        rec = run(n, nh, method, c, E_max, A)
        print(f"{n}^2 x {nh} modes ({method}): {rec['seconds']:.1f} s, "
              f"{rec.get('factor_MB', 0):.0f} MB of factors, it {rec.get('iterations')}, "
              f"neg {rec['negative_fraction']:.1e}", flush=True)
        out.append(rec)
    ref = np.asarray(out[-1]["pA"])
    for rec in out:
        rec["L1_to_finest"] = float(np.trapezoid(np.abs(np.asarray(rec["pA"]) - ref), A))
    from vifpk.harness.workflows.compare import compare

    mc = monte_carlo(np.linspace(0, A[-1], 101), 0.01 if quick else 0.005)
    for rec in out:
        m = compare({"x": A, "p": np.asarray(rec["pA"])}, mc["data"])
        rec["L1_to_mc"], rec["mc_floor"] = m["L1"], m["L1_floor"]
        print(f"{rec['cells']}^2 x {rec['modes']}: L1 to finest {rec['L1_to_finest']:.2g}, "
              f"to MC {m['L1']:.3g} (floor {m['L1_floor']:.3g})")
        del rec["pA"]
    dest = ROOT / "benchmarks" / "results" / "fpk2d_ou.json"
    dest.write_text(json.dumps({"scene": "paper-base with mu = 0 (no sticking atom)",
                                "grids": out, "montecarlo": {"seconds_cpu": mc["seconds_cpu"],
                                                             "floor": mc["floor"]},
                                "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())},
                               indent=1))
    print("wrote", dest)


if __name__ == "__main__":
    main()
