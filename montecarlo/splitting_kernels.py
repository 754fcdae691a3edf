"""The conventions and bookkeeping of the splitting estimator's numba kernels (splitting.py): a
path run from a given state until it is absorbed, with the states it had when it first reached
each level of the reaction coordinate (AMS), and the direct simulation of the cycles (the
cycle decomposition). Both pairs run their paths in vector lanes, with this module's
conventions and bookkeeping helpers: the original system's (``advance_orig``,
``cycles_orig``) in splitting_lanes.py, the averaged SDE's (``advance_sde``, ``cycles_sde``)
in sde_lanes_splitting.py.

Two dynamics, each with its own pair of kernels and the same conventions:
- the averaged amplitude SDE, state row (Z = A^2, t); the step is averaged_sde.sde_step (not a
  copy), and the reaction coordinate is q = Z;
- the original system, state row (x, v, xi, t, time at rest); the step is kernels.strang_step (not a
  copy), and the reaction coordinate is the energy q = E = v^2/2 + U(x) (geometry.energy).
  The state at rest needs no flag of its own: the kernel's rest is v == 0 exactly (and x == 0
  at the wall), which the copied row carries.

Levels: q_lo < q_hi and ``levels`` = M; the level of a state is
xi(q) = min(M, floor((q - q_lo) M / (q_hi - q_lo))) (0 below q_lo). A path is absorbed at q <= q_lo
(a return: outcome 0) or q >= q_hi (a success, level M: outcome 1); outcome -1 when it reached
``t_max`` first. ``recs[row, j]`` is the state at the first step where the level was >= j.

Random numbers: each path is given its own four generator words by the caller (a fresh stream
for every path and every clone), so the results do not depend on the thread count.

Crossings inside a step: for the SDE, a step that ends short of a boundary (A_lo = sqrt(q_lo)
or A_hi = sqrt(q_hi)) is counted as a crossing with the Brownian-bridge probability
exp(-2 (A_n - b)(A_{n+1} - b) / (sigma^2 h)) (sigma frozen over the step), which removes the
O(sqrt h) bias of a discretely monitored boundary (Broadie, Glasserman & Kou 1997; Gobet 2000);
for the original system the energy's own test (passage_kernels.bridge_hit, sigma_H^2 of
passage.py's docstring: white external noise and the Stratonovich parametric noises) at the two
boundaries q_lo (a return; in cycles_orig the arming below q0) and q_hi (a success), with the
physics record's B = (bridge, pk, pc); under OU noise alone the energy is C^1 in time, B is all
None, so a missed crossing costs O(h^2) per step and none is drawn. The burn-in of cycles_orig
tests q_hi at the step ends only. A success's time is interpolated linearly inside the step.
"""

from __future__ import annotations

from ._jit import jit
from .geometry import orbit_start

OUT_FAIL, OUT_SUCCESS, OUT_TIMEOUT = 0, 1, -1
BRIDGE_CUT = 40.0  # no uniform is drawn when the bridge probability is below e^-40
MAX_RESTARTS = 100  # burn-ins a path may begin again (cycles_orig)


@jit(inline="always")
def level_of(q, q_lo, inv_dq, M):
    """The level xi(q) of the module docstring."""
    if q <= q_lo:
        return 0
    u = (q - q_lo) * inv_dq
    if u >= M:
        return M
    return int(u)


@jit(inline="always")
def _cycle_success(tc, in_cycle, t_cycle, k, total, succ, summary, p):
    """The threshold reached at time tc: the cycle in progress ends with a success, or the
    warm-up ends at the threshold (summary[p, 0:2]). Returns (k, total, succ)."""
    if in_cycle:
        return k + 1, total + (tc - t_cycle), succ + 1
    summary[p, 0] = tc
    summary[p, 1] = 1.0
    return k, total, succ


@jit(inline="always")
def _cycle_start(t, in_cycle, t_cycle, k, total, n_cycles, summary, p):
    """A cycle start at time t (the first step at q >= q1 after a visit to q <= q0): ends the
    cycle in progress, or the warm-up (summary[p, 0]). Returns (k, total, done: n_cycles
    complete)."""
    if in_cycle:
        k += 1
        total += t - t_cycle
        if k >= n_cycles:
            return k, total, True
    else:
        summary[p, 0] = t
    return k, total, False


@jit(inline="always")
def _cycle_summary(summary, p, k, total, succ):
    summary[p, 2] = k
    summary[p, 3] = total
    summary[p, 4] = succ


@jit
def orbit_starts(A, out, rng, w0sq, alpha, khi, walls, P):
    """out[p] = (x, v, xi, 0, 0) from geometry.orbit_start (phase uniform in time on the
    conservative orbit of amplitude A, on the walls' elastic orbit, xi from its stationary
    law: the kind of the kernels' record P), with the generator words rng[p]; walls = (fold,
    lo, up)."""
    fold, lo, up = walls
    for p in range(out.shape[0]):
        x, v, xi, _s0, _s1, _s2, _s3 = orbit_start(A, w0sq, alpha, khi, fold, lo, up, P,
                                                   rng[p, 0], rng[p, 1], rng[p, 2], rng[p, 3])
        out[p, 0] = x
        out[p, 1] = v
        out[p, 2] = xi
        out[p, 3] = 0.0
        out[p, 4] = 0.0
