"""Monte Carlo of a one-dimensional averaged amplitude SDE  dA = m(A) dt + sigma(A) dB.

It lets the harness split the error of an averaged model into sampling error (this MC
against the closed form of the same SDE) and averaging error (the original system's MC
against the closed form).

The drift of an amplitude equation is singular at A = 0 (m ~ sigma^2 / (2A)), and Euler-
Maruyama on A overshoots below zero. We simulate Z = A^2 instead (Ito):

    dZ = (2 A m + sigma^2) dt + 2 A sigma dB,

whose drift is regular; near 0 it is a squared Bessel process of dimension 2 (drift
2 sigma^2), on the Feller boundary, where Euler-Maruyama on Z is poor (measured: the first
histogram bin short by 6 standard errors at dt = 0.01 for the Rayleigh case; a one-noise
Milstein step, which keeps Z >= sigma^2 h, still by 4). We split the drift as
2 sigma^2 + (2Am - sigma^2) and take the BESQ(2) part exactly for frozen sigma, as the squared
radius of a 2-D Brownian step:

    Z_{n+1} = (A_n + sigma dB_1)^2 + (sigma dB_2)^2 + (2 A_n m - sigma^2) h,

where 2Am - sigma^2 -> 0 as A -> 0 (2m/sigma^2 ~ 1/A for an amplitude equation). Weak order 1
(frozen sigma, explicit remainder). A rare negative Z (strong inward drift at large A) is
reflected. 2Am - sigma^2 and sigma are tabulated from the caller's m, sigma^2 on a uniform
grid and interpolated linearly; beyond the table the last value is used (the table should
reach well past the support).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

import numba
import numpy as np
from vifpk.montecarlo.stepper import CHUNK_SECONDS
from vifpk.montecarlo.summary import density, mean_se

from vifpk.core.defaults import BURN_FACTOR, FPK_CELLS
from vifpk.core.result import Resolved, Result, Status

from ._jit import jit, over_blocks
from .geometry import amplitude_general, orbit_position, potential
from .lanes import LANES, fast_normal
from .rng import block_seeds, normal

ORDER = 1
#: dt = "auto": the largest sample_every / k not above tau / STEPS_PER_TAU. The averaged SDE
#: lives on the slow time scale of the amplitude (tau ~ 90 on the paper's base scene), not on
#: the oscillation's, which sets the original system's step. Measured on paper-base
#: (1024 paths x 2000 time units, two seeds, docs/montecarlo.md): no bias of p(A) against the
#: closed form of any of the three models at dt = 0.05, 0.1 or 0.25 (L1 0.45-1.3 x its noise
#: floor of 0.01, as at dt = 0.01); tau / 1000 is 0.09 there, a margin of about 3 in dt.
STEPS_PER_TAU = 1000.0
LOG_DEPTH = 60.0  # relaxation_time: cells where pi > e^-60 of its peak


def relaxation_time(drift: Callable[[np.ndarray], np.ndarray],
                    diffusion: Callable[[np.ndarray], np.ndarray], top: float,
                    cells: int = FPK_CELLS, depth: float = LOG_DEPTH) -> float:
    """Slowest relaxation time 1 / lambda_1 of THIS SDE, from its own generator
    L f = (1/pi) (pi sigma^2 / 2 f')' (pi the stationary density, reflecting ends), discretised
    on ``cells`` cells and symmetrised by sqrt(pi): a tridiagonal eigenproblem.
    Used for ``burn_in = "auto"``: a 1-D SDE's relaxation time is a property of the SDE
    itself, so no pilot run is needed.

    The cells cover the part of [0, top] where log pi is within ``depth`` of its maximum
    (found on a 4x finer grid), with reflecting ends there. Beyond it the density is below
    e^-depth of its peak and the inward drift is steep, so the region relaxes fast and holds
    no slow mode; kept in, it would give the matrix a dynamic range (e^(g h / 2) per cell)
    that drowns lambda_1 in round-off. The matrix is built from neighbour differences of
    log pi only, never from pi: a floor on log pi (as once here) turned the far tail into a
    flat, driftless region whose slow diffusion posed as the slowest mode (tau grew without
    bound with the table's top: 1454 instead of 92 for the base scene's exact model at check's
    table; tests/test_montecarlo.py measures it against the CIR closed form).
    A diffusion that vanishes somewhere on the kept cells gives an infinite tau (the caller
    then falls back to a fixed burn-in)."""
    from scipy.linalg import eigh_tridiagonal

    def log_pi(A: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
        s2 = np.maximum(np.asarray(diffusion(A), float), 1e-300)
        g = 2 * np.asarray(drift(A), float) / s2
        d = 0.5 * (g[1:] + g[:-1]) * h - np.diff(np.log(s2))  # log pi_{i+1} - log pi_i
        return np.concatenate([[0.0], np.cumsum(d)]), s2

    fine = 4 * cells
    hf = top / fine
    lp, _ = log_pi((np.arange(fine) + 0.5) * hf, hf)
    keep = np.flatnonzero(lp >= lp.max() - depth)
    lo, hi = keep[0] * hf, (keep[-1] + 1) * hf
    h = (hi - lo) / cells
    lp, s2 = log_pi(lo + (np.arange(cells) + 0.5) * h, h)
    d = np.diff(lp)
    # c = pi sigma^2 / 2 and c at a face sqrt(c_i c_{i+1}) give, with s = sqrt(s2_i s2_i+1)/2:
    #   c_face / pi_i = s e^{+d/2},  c_face / pi_{i+1} = s e^{-d/2},  c_face / sqrt(pi_i pi_i+1) = s
    s_face = 0.5 * np.sqrt(s2[1:] * s2[:-1])
    diag = np.zeros(cells)
    with np.errstate(over="ignore", invalid="ignore"):  # a vanishing sigma^2: checked below
        diag[:-1] += s_face * np.exp(0.5 * d)
        diag[1:] += s_face * np.exp(-0.5 * d)
        diag /= h * h
    off = -s_face / (h * h)
    if not (np.all(np.isfinite(diag)) and np.all(np.isfinite(off))):
        return math.inf  # sigma^2 -> 0 on a kept cell: no finite relaxation rate to compute
    lam = eigh_tridiagonal(diag, off, select="i", select_range=(0, 1),
                           eigvals_only=True)
    return float(1.0 / lam[1]) if lam[1] > 0 else math.inf


@jit(inline="always")
def sde_coefficients(Z, a_tab, b_tab, inv_d, last):
    """(A = sqrt(Z), a, b): the tables a_tab = 2 A m - sigma^2 and b_tab = sigma interpolated
    linearly at A on the grid A_j = j / inv_d (``sde_tables``; beyond it the last value),
    last = a_tab.size - 1."""
    A = math.sqrt(Z)
    a, b = sde_coefficients_at(A, a_tab, b_tab, inv_d, last)
    return A, a, b


@jit(inline="always")
def sde_coefficients_at(A, a_tab, b_tab, inv_d, last):
    """(a, b) of ``sde_coefficients`` at the amplitude A = sqrt(Z) (a caller that has it: the
    lane kernels, whose tests take that square root after each step)."""
    u = A * inv_d
    j = int(u)
    if j >= last:
        return a_tab[last], b_tab[last]
    w = u - j
    return (1.0 - w) * a_tab[j] + w * a_tab[j + 1], (1.0 - w) * b_tab[j] + w * b_tab[j + 1]


@jit(inline="always")
def sde_update(A, a, bb, z, z2, h, sq):
    """(new Z, whether it was reflected): the scheme of the module docstring with the two
    normals z, z2 (sq = sqrt(h))."""
    y = A + bb * sq * z
    y2 = bb * sq * z2
    Z = y * y + y2 * y2 + a * h
    refl = Z < 0.0
    if refl:
        Z = -Z
    return Z, refl


@jit(inline="always")
def sde_step(Z, s0, s1, s2, s3, h, sq, a_tab, b_tab, inv_d, last):
    """One step of the scheme of the module docstring from Z = A^2: (new Z, sigma(A) used,
    whether Z was reflected, generator state). a_tab = 2 A m - sigma^2 and b_tab = sigma on
    the grid A_j = j / inv_d (``sde_tables``), last = a_tab.size - 1, sq = sqrt(h)."""
    A, a, bb = sde_coefficients(Z, a_tab, b_tab, inv_d, last)
    z, s0, s1, s2, s3 = normal(s0, s1, s2, s3)
    z2, s0, s1, s2, s3 = normal(s0, s1, s2, s3)
    Z, refl = sde_update(A, a, bb, z, z2, h, sq)
    return Z, bb, refl, s0, s1, s2, s3


def sde_tables(drift: Callable[[np.ndarray], np.ndarray],
               diffusion: Callable[[np.ndarray], np.ndarray], top: float,
               table_points: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(grid, a_tab, b_tab) for ``sde_step``: a = 2 A m(A) - sigma^2(A) and b = sigma(A) on
    ``table_points`` uniform points of [0, top], the value at A = 0 extrapolated linearly.
    ValueError when drift or diffusion is not finite there."""
    grid = np.linspace(0.0, top, table_points)
    inner = grid[1:]
    m, s2 = np.asarray(drift(inner), float), np.asarray(diffusion(inner), float)
    a_inner = 2.0 * inner * m - s2
    a_tab = np.concatenate([[2.0 * a_inner[0] - a_inner[1]], a_inner])  # linear extrapolation
    sig = np.sqrt(np.maximum(s2, 0.0))
    b_tab = np.concatenate([[2.0 * sig[0] - sig[1]], sig])
    if not (np.all(np.isfinite(a_tab)) and np.all(np.isfinite(b_tab))):
        raise ValueError("drift or diffusion is not finite on the table")
    return grid, a_tab, b_tab


def run_sde_blocks(states, p0, n_paths, n_burn, n_samples, stride, h, a_tab, b_tab, dA_tab,
                   z0, a_lo, a_inv, hist_A, sums, barrier, w_lo, w_up, w0sq, alpha, khi, x_lo,
                   x_inv, hist_x, v_lo, v_inv, hist_v, obs_tab, ow0sq, oalpha, okhi):
    """Paths p0 .. p0 + n_paths - 1 of every block b, each from Z = z0 with its own generator
    words states[b, p] (updated in place): histogram of A and sums (A, A^2, samples,
    reflections) per block after burn-in.
    a_tab = 2 A m(A) - sigma^2 on the grid A_j = j dA_tab, b_tab = sigma(A) there.
    With hist_x / hist_v, each sample also records a time-uniform point of the orbit of
    amplitude A as the system moves on it (geometry.orbit_position, the original system's starts):
    with the paper's ``barrier`` folded, x1 = |y|, x2 = y' sgn(y); with walls at
    w_lo <= 0 <= w_up (+-inf: none) the elastic orbit cut at them (impacts on alternate
    walls), i.e. the free orbit's time-uniform law conditioned on [w_lo, w_up]: the averaged
    model's own phase-space density, p(y, y') = p(E) / T(E), T the truncated period.
    With a non-empty obs_tab (rms fast energy fluctuation on the same grid as a_tab), each
    sampled A is observed as A' = U^{-1}(U(A) + sd(A) z), z ~ N(0, 1) redrawn while the energy
    is negative (U(x) = ow0sq x^2 / 2 + oalpha x^4 / 4): the model's observation map applied
    to samples; A' is then recorded (and its orbit point).

    The paths of a block advance LANES at a time in struct-of-arrays lanes (lanes.py's
    pattern: the step with the ziggurat's fast path on every lane in one loop, a lane whose
    normal took the slow path stepped again from its start by ``sde_step``), so each path's
    numbers are those of ``sde_step`` alone with its words. A block's float sums are taken step
    by step over its groups of LANES paths: p0 must be a multiple of LANES (``simulate_sde``
    cuts its calls so), and any such cut, thread count or executor gives the same bits. One
    block per thread at a time (``_jit.over_blocks``)."""
    over_blocks(_sde_block, states.shape[0], states, p0, n_paths, n_burn, n_samples, stride, h,
                (a_tab, b_tab, dA_tab), z0, (a_lo, a_inv), hist_A, sums,
                (barrier, w_lo, w_up, w0sq, alpha, khi), (x_lo, x_inv), hist_x, (v_lo, v_inv),
                hist_v, (obs_tab, ow0sq, oalpha, okhi))


@jit
def _observe(A, inv_d, last, obs_tab, ow0sq, oalpha, okhi, s0, s1, s2, s3):
    """The observation map of ``run_sde_blocks`` on a sampled A (with the path's words)."""
    u = A * inv_d
    j = int(u)
    if j >= last:
        sd = obs_tab[last]
    else:
        w = u - j
        sd = (1.0 - w) * obs_tab[j] + w * obs_tab[j + 1]
    E = potential(A, ow0sq, oalpha, okhi)
    while True:
        z, s0, s1, s2, s3 = normal(s0, s1, s2, s3)
        Eo = E + sd * z
        if Eo >= 0.0:
            break
    if okhi is None:
        A = math.sqrt(4.0 * Eo / (ow0sq + math.sqrt(ow0sq * ow0sq + 4.0 * oalpha * Eo)))
    else:  # the amplitude of energy Eo: the orbit through x = 0, v^2/2 = Eo
        A = amplitude_general(0.0, math.sqrt(2.0 * Eo), ow0sq, oalpha, okhi)
    return A, s0, s1, s2, s3


@jit(nogil=True)
def _sde_block(first, every, states, p0, n_paths, n_burn, n_samples, stride, h, tabs, z0,
               bins, hist_A, sums, geo, xbin, hist_x, vbin, hist_v, obs):
    """run_sde_blocks for blocks first, first + every, ... (one thread's share)."""
    a_tab, b_tab, dA_tab = tabs
    a_lo, a_inv = bins
    barrier, w_lo, w_up, w0sq, alpha, khi = geo
    x_lo, x_inv = xbin
    v_lo, v_inv = vbin
    obs_tab, ow0sq, oalpha, okhi = obs
    observe = obs_tab.size > 0
    total = n_burn + n_samples * stride
    sq = math.sqrt(h)
    last = a_tab.size - 1
    inv_d = 1.0 / dA_tab
    Zs = np.zeros((2, LANES))  # Z, Z at the step's start
    R = np.zeros(LANES, dtype=np.bool_)
    S = np.zeros((8, LANES), dtype=np.uint64)  # words, words at the step's start
    for b in range(first, states.shape[0], every):
        for g0 in range(p0, p0 + n_paths, LANES):
            m = min(LANES, p0 + n_paths - g0)
            for j in range(m):
                Zs[0, j] = z0
                for w in range(4):
                    S[w, j] = states[b, g0 + j, w]
            Z, Z0 = Zs[0], Zs[1]
            S0, S1, S2, S3, T0, T1, T2, T3 = S[0], S[1], S[2], S[3], S[4], S[5], S[6], S[7]
            for n in range(total):
                for j in range(m):  # the step on every lane (NaN: a slow-path normal)
                    s0, s1, s2, s3 = S0[j], S1[j], S2[j], S3[j]
                    Z0[j], T0[j], T1[j], T2[j], T3[j] = Z[j], s0, s1, s2, s3
                    A, a, bb = sde_coefficients(Z[j], a_tab, b_tab, inv_d, last)
                    z, s0, s1, s2, s3 = fast_normal(s0, s1, s2, s3)
                    z2, s0, s1, s2, s3 = fast_normal(s0, s1, s2, s3)
                    Z[j], R[j] = sde_update(A, a, bb, z, z2, h, sq)
                    S0[j], S1[j], S2[j], S3[j] = s0, s1, s2, s3
                for j in range(m):  # those lanes again, by sde_step
                    if Z[j] == Z[j]:
                        continue
                    Z[j], _sig, R[j], S0[j], S1[j], S2[j], S3[j] = sde_step(
                        Z0[j], T0[j], T1[j], T2[j], T3[j], h, sq, a_tab, b_tab, inv_d, last)
                if n < n_burn:
                    continue
                for j in range(m):
                    if R[j]:
                        sums[b, 3] += 1.0
                if (n - n_burn + 1) % stride != 0:
                    continue
                for j in range(m):
                    A = math.sqrt(Z[j])
                    if observe:
                        A, S0[j], S1[j], S2[j], S3[j] = _observe(
                            A, inv_d, last, obs_tab, ow0sq, oalpha, okhi, S0[j], S1[j], S2[j],
                            S3[j])
                    i = math.floor((A - a_lo) * a_inv)
                    if 0 <= i < hist_A.shape[1]:
                        hist_A[b, i] += 1.0
                    sums[b, 0] += A
                    sums[b, 1] += A * A
                    sums[b, 2] += 1.0
                    if hist_x is not None:  # on the orbit as it is: folded, or cut at walls
                        y, yp, S0[j], S1[j], S2[j], S3[j] = orbit_position(
                            A, w0sq, alpha, khi, barrier, w_lo, w_up, S0[j], S1[j], S2[j],
                            S3[j])
                        ix = math.floor((y - x_lo) * x_inv)
                        if 0 <= ix < hist_x.shape[1]:
                            hist_x[b, ix] += 1.0
                        iv = math.floor((yp - v_lo) * v_inv)
                        if 0 <= iv < hist_v.shape[1]:
                            hist_v[b, iv] += 1.0
            for j in range(m):
                for w in range(4):
                    states[b, g0 + j, w] = S[w, j]


def _spring(d: dict[str, Any]) -> tuple[float, float, np.ndarray | None]:
    """(w0sq, alpha, khi) of the kernels from {"restoring": (k1, k3, ...)} or the paper's
    {"omega0", "alpha"}; khi = (k5, ...) or None (trailing zeros dropped)."""
    k = (tuple(float(c) for c in d["restoring"]) if "restoring" in d
         else (float(d["omega0"]) ** 2, float(d["alpha"])))
    k = k + (0.0,) * (2 - len(k))
    while len(k) > 2 and k[-1] == 0.0:
        k = k[:-1]
    return k[0], k[1], (np.array(k[2:]) if len(k) > 2 else None)


def simulate_sde(drift: Callable[[np.ndarray], np.ndarray],
                 diffusion: Callable[[np.ndarray], np.ndarray], *, edges: np.ndarray,
                 A_table: float | None = None, table_points: int = 4001, paths: int = 1024,
                 blocks: int = 32, dt: float | str = 0.01, time_: float = 2000.0,
                 burn_in: float | str = "auto", sample_every: float = 0.5,
                 seed: int = 20190102,
                 A0: float | None = None, phase: dict[str, Any] | None = None,
                 observe: dict[str, Any] | None = None, threads: int | None = None) -> Result:
    """Histogram of A for the averaged SDE with batch error bars (blocks are the batches).

    phase: optional ``{"restoring" (k1, k3, ...) or "omega0" and "alpha", "barrier",
    "edges_x", "edges_v"[, "lower", "upper"]}`` to also record x1, x2 from time-uniform
    points of the orbit of each sampled amplitude: folded onto x >= 0 with the paper's
    ``barrier``, cut at walls ``lower`` <= 0 <= ``upper`` otherwise (default: none).
    burn_in: a time, or "auto": BURN_FACTOR x relaxation_time(drift, diffusion).
    dt: a step, or "auto": the largest sample_every / k not above tau / STEPS_PER_TAU (tau the
    relaxation time; sample_every / 10 when tau is not finite).
    observe: optional ``{"sd": callable, "restoring" or "omega0" and "alpha"}``: an
    observation map on the
    sampled energy (sd(A) the rms of a normal fluctuation of U(A), truncated at U >= 0), as
    the model applies to its closed form (averaging.corrected.CorrectedModel.observe).
    threads: numba's threads for this run in the calling thread (0: all cores; None: as the
    calling thread has them); the numbers are the same for any."""
    if threads is not None:
        numba.set_num_threads(threads or numba.config.NUMBA_NUM_THREADS)
    edges = np.asarray(edges, dtype=float)
    top = float(A_table if A_table is not None else 1.5 * edges[-1])
    tau = None
    if burn_in == "auto" or dt == "auto":
        tau = relaxation_time(drift, diffusion, top)
    if burn_in == "auto":
        burn_in = BURN_FACTOR * tau if math.isfinite(tau) else 300.0
    burn_in = float(burn_in)
    dt_mode = "auto" if dt == "auto" else "fixed"
    if dt == "auto":
        target = tau / STEPS_PER_TAU if math.isfinite(tau) else sample_every / 10.0
        dt = sample_every / math.ceil(sample_every / target * (1 - 1e-12))
    dt = float(dt)
    grid, a_tab, b_tab = sde_tables(drift, diffusion, top, table_points)
    inner = grid[1:]
    if observe is not None:
        o_sd = np.asarray(observe["sd"](inner), float)
        obs_tab = np.concatenate([[o_sd[0]], o_sd])
        obs_geo = _spring(observe)
        if not np.all(np.isfinite(obs_tab)):
            raise ValueError("the observation map's sd is not finite on the table")
    else:
        obs_tab, obs_geo = np.zeros(0), (1.0, 0.0, None)
    n_burn = int(round(burn_in / dt))
    stride = max(int(round(sample_every / dt)), 1)
    n_samples = max(int(time_ / (stride * dt)), 1)
    per_block = paths // blocks
    states = block_seeds(seed, blocks, per_block)  # path p of block b: its own stream
    z0 = (A0 if A0 is not None else 0.5 * (edges[0] + edges[-1])) ** 2
    hist = np.zeros((blocks, edges.size - 1))
    sums = np.zeros((blocks, 4))
    if phase is not None:
        ex = np.asarray(phase["edges_x"], dtype=float)
        ev = np.asarray(phase["edges_v"], dtype=float)
        geo = (bool(phase["barrier"]), float(phase.get("lower", -math.inf)),
               float(phase.get("upper", math.inf)), *_spring(phase))
        hx, hv = np.zeros((blocks, ex.size - 1)), np.zeros((blocks, ev.size - 1))
    else:
        ex = ev = np.array([0.0, 1.0])
        geo = (True, -math.inf, math.inf, 1.0, 0.0, None)
        hx = hv = None

    def call(st, p0, n_p, n_b, n_s, stride_, hA, sm, hx_, hv_):
        run_sde_blocks(st, p0, n_p, n_b, n_s, stride_, dt, a_tab, b_tab, grid[1] - grid[0], z0,
                       edges[0], 1.0 / (edges[1] - edges[0]), hA, sm, *geo,
                       ex[0], 1.0 / (ex[1] - ex[0]), hx_, ev[0], 1.0 / (ev[1] - ev[0]), hv_,
                       obs_tab, *obs_geo)

    t0 = time.perf_counter()
    call(states[:1, :1].copy(), 0, 1, 1, 1, 1, np.zeros((1, edges.size - 1)), np.zeros((1, 4)),
         None if hx is None else np.zeros((1, ex.size - 1)),
         None if hv is None else np.zeros((1, ev.size - 1)))
    compile_s = time.perf_counter() - t0
    t1 = time.perf_counter()
    # in calls of about CHUNK_SECONDS, so that Ctrl-C is seen between them: each call runs
    # the next k paths of every block, k a multiple of LANES (run_sde_blocks: the groups of
    # lanes, and so the order of a block's sums, are those of one call), each path with its
    # own generator words, so any such cut gives the same numbers as one call
    path_steps = blocks * (n_burn + n_samples * stride)
    rate = 5e6 * numba.get_num_threads()  # steps per second: a first guess, then measured
    done = 0
    while done < per_block:
        k = int(max(1, min(per_block - done, CHUNK_SECONDS * rate / max(path_steps, 1))))
        k = min(per_block - done, -(-k // LANES) * LANES)
        t = time.perf_counter()
        call(states, done, k, n_burn, n_samples, stride, hist, sums, hx, hv)
        spent = time.perf_counter() - t
        if spent > 0:
            rate = k * path_steps / spent
        done += k
    run_s = time.perf_counter() - t1
    d = density(hist, sums[:, 2], np.diff(edges))
    steps = float(blocks * per_block * (n_burn + n_samples * stride))
    info: dict[str, Any] = {
        "solver": "averaged-sde",
        "order": {"weak": ORDER, "note": "exact BESQ(2) part + explicit remainder, Z = A^2"},
        "settings": {"paths": blocks * per_block, "dt": dt, "dt_mode": dt_mode,
                     "time": n_samples * stride * dt,
                     "burn_in": n_burn * dt, "sample_every": stride * dt, "blocks": blocks,
                     "table_points": table_points, "A_table": top},
        "seed": {"root": seed, "scheme": "path p of block b: words 4p..4p+3 of "
                 "numpy.random.SeedSequence(root, spawn_key=(b,)).generate_state"},
        "relaxation_time": tau,
        "L1_floor": {"A": d["L1_floor"]},
        "moments": {"A": {"mean": mean_se(sums[:, 0] / sums[:, 2]),
                          "second": mean_se(sums[:, 1] / sums[:, 2])}},
        "reflections_per_sample": float(sums[:, 3].sum() / sums[:, 2].sum()),
        "seconds": {"compile": compile_s, "run": run_s, "total": compile_s + run_s},
        "steps": steps, "steps_per_second": steps / run_s if run_s > 0 else math.nan,
        "status": (Status.SIMULATED if np.all(np.isfinite(d["p"])) else Status.NOT_FINITE
                   ).record(),
    }
    data = {"A": {"x": 0.5 * (edges[1:] + edges[:-1]), "p": d["p"], "edges": edges,
                  "err": d["err"], "p_blocks": d["blocks"]}}
    if hx is not None:
        for name, hh, e in (("x1", hx, ex), ("x2", hv, ev)):
            dd = density(hh, sums[:, 2], np.diff(e))
            data[name] = {"x": 0.5 * (e[1:] + e[:-1]), "p": dd["p"], "edges": e,
                          "err": dd["err"], "p_blocks": dd["blocks"]}
            info["L1_floor"][name] = dd["L1_floor"]
    cfg = info["settings"]
    return Result(data=data, info=info, resolved=Resolved(
        dt=cfg["dt"], burn_in=cfg["burn_in"], time=cfg["time"], paths=cfg["paths"],
        blocks=cfg["blocks"], sample_every=cfg["sample_every"]))
