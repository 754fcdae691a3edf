"""The stationary kernel (``run_paths``) with its paths in struct-of-arrays lanes (issue 44).

Lane j of the scratch rows is path p0 + j of a block; LANES paths advance together, one step
at a time, in two loops over the lanes (``lane_step``):

1. **the smooth step on every lane**, in one loop the compiler vectorises: the step of
   ``kernels.strang_step`` where it meets no event, with the same arithmetic: the drifts where
   no wall is crossed (``smooth_drift``), the velocity stage where v keeps its sign and k h is
   in exp_phi's series (``smooth_flow``), the ziggurat where it accepts at once
   (``fast_normal``). The noise kind's own pieces make the step: its ``velocity`` and
   ``advance`` factories, which step ONE path's scalar state and generator, are compiled
   here with ``smooth_flow`` and ``fast_normal`` in place of ``velocity_flow`` and
   ``rng.normal`` (``velocity_smooth``, ``advance_smooth``). Where an event would happen, these
   return NaN, which the rest of the step carries to the lane's state;
2. **the lanes that met an event**, an impact, a velocity zero (sticking, stick-slip), a
   large k h, the ziggurat's slow path, or a state already non-finite, are stepped again
   from their start by ``strang_step``, one by one.

Every lane's new state is therefore that of ``strang_step``, bit for bit, and its generator
words are advanced by the same draws: the results are those of the kernel that stepped each
path alone, for any group, lane, thread count and cut into calls (tests/test_montecarlo.py;
benchmarks/mc_identity.py). The energy balance (``keep``) and parametric noise step every lane
by ``strang_step`` (the balance reads each sub-flow's velocities; the parametric sub-flows draw
their normals outside the kind's pieces). Measured (benchmarks/bench_kernel_bound.py): the
kernel within 1.2x of a minimal kernel of the same scheme in the same layout, 1.6x faster than
that minimal kernel with 4 paths in turn (the layout before).

LANES is a compile-time constant (one machine code for every run; a block's last group runs
as many lanes as it has paths); the scratch is allocated once per kernel call.
"""

from __future__ import annotations

import math

import numpy as np
from numba.extending import overload

from ._jit import jit, over_blocks
from .geometry import amplitude_general
from .kernels import (
    EN_DAMP,
    EN_FRICTION,
    EN_IMPACT,
    EN_INPUT,
    EV_ATOM,
    EV_CHATTER,
    EV_IMPACTS,
    EV_OUT_A,
    EV_OUT_V,
    EV_OUT_X,
    EV_SAMPLES,
    EV_TIME,
    MO_A,
    MO_A2,
    MO_MAXA,
    MO_MAXV,
    MO_MAXX,
    MO_V,
    MO_V2,
    MO_X,
    MO_X2,
    damping_k,
    decay,
    spring_g,
    strang_step,
)
from .pieces import _module_of as kind_module
from .pieces import noise_energy
from .rng import KN, U64, WN, next_u64

LANES = 32  # paths advanced together (a block's paths in groups of LANES)

# rows of the float scratch: the lane state, its copy at the step's start, what the sampling
# and the energy balance read
(L_X, L_V, L_XI, L_REST, L_X0, L_V0, L_XI0, L_K, L_LOSS1, L_LOSS2, L_DV1, L_DV2, L_VB, L_VC,
 L_VK, L_VD, L_VE, L_XIU, L_WP) = range(19)
N_FLOAT = 19


@jit(inline="always")
def scratch():
    """(float rows, generator words: 4 rows now, 4 at the step's start) for LANES paths."""
    return np.zeros((N_FLOAT, LANES)), np.zeros((8, LANES), dtype=np.uint64)


@jit(inline="always")
def load(m, F, S, rng, state, stuck_time, b, p0):
    """Paths p0 .. p0 + m - 1 of block b into lanes 0 .. m - 1."""
    for j in range(m):
        F[L_X, j], F[L_V, j], F[L_XI, j] = state[b, p0 + j, 0], state[b, p0 + j, 1], \
            state[b, p0 + j, 2]
        F[L_REST, j] = stuck_time[b, p0 + j]
        for w in range(4):
            S[w, j] = rng[b, p0 + j, w]


@jit(inline="always")
def store(m, F, S, rng, state, stuck_time, b, p0):
    """The inverse of ``load``."""
    for j in range(m):
        state[b, p0 + j, 0], state[b, p0 + j, 1], state[b, p0 + j, 2] = F[L_X, j], F[L_V, j], \
            F[L_XI, j]
        stuck_time[b, p0 + j] = F[L_REST, j]
        for w in range(4):
            rng[b, p0 + j, w] = S[w, j]


@jit(inline="always")
def move(F, S, L, Li, src, dst):
    """Lane src into lane dst: its state, generator words and what its step left for the
    caller (every row of F and S), and the caller's own float and int lane rows L, Li (a lane
    whose path ended takes the last lane's path, stepped but not yet read: first passage,
    splitting)."""
    for r in range(F.shape[0]):
        F[r, dst] = F[r, src]
    for r in range(S.shape[0]):
        S[r, dst] = S[r, src]
    for r in range(L.shape[0]):
        L[r, dst] = L[r, src]
    for r in range(Li.shape[0]):
        Li[r, dst] = Li[r, src]


@jit(inline="always")
def drop(F, S, L, Li, i, m):
    """Lane i's path has ended (its results written by the caller): the last of the m busy
    lanes moves into lane i (``move``; its path stepped but not yet read, so the caller reads
    lane i again). Returns the number of busy lanes left."""
    m -= 1
    if i < m:
        move(F, S, L, Li, m, i)
    return m


# ------------------------------------------------------------- the speculative smooth step
_C6, _C24, _C120 = 1.0 / 6.0, 1.0 / 24.0, 1.0 / 120.0  # as kernels.exp_phi's series


@jit
def smooth_flow(v, tau, F, k, mu, at_wall):
    """kernels.velocity_flow where it meets no event, the same arithmetic (exp_phi's series,
    |k tau| < 0.02; with friction: v != 0 and no zero of v inside the sub-step); NaN where
    it would meet one (the lane is then stepped again by ``strang_step``)."""
    z = k * tau
    z2 = z * z
    phi = (1.0 - 0.5 * z) + z2 * ((_C6 - _C24 * z) + _C120 * z2)
    e = 1.0 - z * phi
    if mu is None:
        vt = v * e + F * tau * phi
        return (vt if abs(z) < 0.02 else math.nan), 0.0
    s = 1.0 if v > 0.0 else -1.0
    vt = v * e + (F - mu * s) * tau * phi
    return (vt if abs(z) < 0.02 and v != 0.0 and vt * s > 0.0 else math.nan), 0.0


@jit(inline="always")
def fast_normal(s0, s1, s2, s3):
    """rng.normal where the ziggurat accepts at once (~97% of draws), the same bits; NaN
    where it would take its rejection or tail path."""
    u, s0, s1, s2, s3 = next_u64(s0, s1, s2, s3)
    iz = np.int64(u & U64(127))
    hz = np.int64(np.int32(np.uint32(u >> U64(32))))
    z = hz * WN[iz]
    return (z if abs(hz) < KN[iz] else math.nan), s0, s1, s2, s3


@jit(inline="always")
def smooth_drift(x, v, tau, lo, hi):
    """pieces.wall_drift where no wall is crossed (lo, hi: -inf, inf without); NaN where one
    is (the lane is then stepped again)."""
    xn = x + v * tau
    return xn if lo <= xn <= hi else math.nan


@jit
def speculate(pk, pc):
    """The smooth step is tried (parametric noise: not; every lane by strang_step)."""
    return pk is None and pc is None


# the noise kind's pieces with the smooth flow and the fast normal (their bodies are never run
# by Python: numba uses the overloads)
def velocity_smooth(rec, v, xi, g, k, mu, at_wall, h, half, s0, s1, s2, s3):  # pragma: no cover
    raise NotImplementedError


def advance_smooth(rec, xi, s0, s1, s2, s3):  # pragma: no cover
    raise NotImplementedError


@overload(velocity_smooth)
def _ol_velocity_smooth(rec, v, xi, g, k, mu, at_wall, h, half, s0, s1, s2, s3):
    return kind_module(rec).velocity(smooth_flow, fast_normal)


@overload(advance_smooth)
def _ol_advance_smooth(rec, xi, s0, s1, s2, s3):
    return kind_module(rec).advance(fast_normal)


@jit(inline="always")
def lane_step(m, F, S, h, half, P, keep, count):
    """One step of lanes 0 .. m - 1 (the module docstring); ``keep``: store what the energy
    balance reads (every lane by strang_step); ``count``: add the events and the time at rest
    (after the burn-in). Returns (impacts, chatter entries) of the step; F[L_X0], F[L_V0] hold
    each lane's x, v before the step and F[L_VC] its velocity at the kick (strang_step's o[8]):
    the bridge tests of first passage and splitting read them (the splitting's, the energy
    before the step from x, v)."""
    # F and S indexed in place, no row views: a view made per step costs two atomic reference
    # counts (and a memory barrier each) per row per step (measured: 5 ns a path-step)
    spec = speculate(P.pk, P.pc) and not keep
    if spec:
        for j in range(m):  # the smooth step, on every lane
            x, v, xi = F[L_X, j], F[L_V, j], F[L_XI, j]
            s0, s1, s2, s3 = S[0, j], S[1, j], S[2, j], S[3, j]
            F[L_X0, j], F[L_V0, j], F[L_XI0, j] = x, v, xi
            S[4, j], S[5, j], S[6, j], S[7, j] = s0, s1, s2, s3
            x = smooth_drift(x, v, half, P.x_lo, P.x_hi)
            k = damping_k(x, P.c1, P.c2, P.dhi)
            g = spring_g(x, P.w0sq, P.alpha, P.khi)
            v, _ = decay(v, half, P.ev)
            v, _, vc, _, _, s0, s1, s2, s3 = velocity_smooth(P, v, xi, g, k, P.mu, 0, h, half,
                                                             s0, s1, s2, s3)
            F[L_VC, j] = vc
            v, _ = decay(v, half, P.ev)
            x = smooth_drift(x, v, half, P.x_lo, P.x_hi)
            xi, s0, s1, s2, s3 = advance_smooth(P, xi, s0, s1, s2, s3)
            F[L_X, j], F[L_V, j], F[L_XI, j] = x, v, xi
            S[0, j], S[1, j], S[2, j], S[3, j] = s0, s1, s2, s3
    impacts = 0
    chatter = 0
    for j in range(m):  # the lanes that met an event (all without the smooth step), in full
        if spec:
            if F[L_X, j] == F[L_X, j] and F[L_V, j] == F[L_V, j] and F[L_XI, j] == F[L_XI, j]:
                continue
            x, v, xi = F[L_X0, j], F[L_V0, j], F[L_XI0, j]
            s0, s1, s2, s3 = S[4, j], S[5, j], S[6, j], S[7, j]
        else:
            x, v, xi = F[L_X, j], F[L_V, j], F[L_XI, j]
            s0, s1, s2, s3 = S[0, j], S[1, j], S[2, j], S[3, j]
            # (every lane's x, v before the step: F[L_X0], F[L_V0], as the smooth loop's)
            F[L_X0, j], F[L_V0, j] = x, v
        x, v, xi, s0, s1, s2, s3, o = strang_step(x, v, xi, s0, s1, s2, s3, h, half, P)
        F[L_X, j], F[L_V, j], F[L_XI, j] = x, v, xi
        S[0, j], S[1, j], S[2, j], S[3, j] = s0, s1, s2, s3
        (imp1, ch1, imp2, ch2, st, k, va, vb, vc, vk, vd, ve, xi_used, dv1, dv2, loss1, loss2,
         wpar) = o
        F[L_VC, j] = vc
        if count:
            impacts += imp1 + imp2
            chatter += ch1 + ch2
            F[L_REST, j] += st
        if keep:
            F[L_K, j], F[L_VB, j], F[L_VK, j], F[L_VD, j] = k, vb, vk, vd
            F[L_VE, j], F[L_XIU, j], F[L_DV1, j], F[L_DV2, j] = ve, xi_used, dv1, dv2
            F[L_LOSS1, j], F[L_LOSS2, j], F[L_WP, j] = loss1, loss2, wpar
    return impacts, chatter


def run_paths(rng, state, n_steps, step0, n_burn, stride, h, P, bins, out, spw):
    """Advance every path of every block by ``n_steps`` steps (global step indices
    ``step0 .. step0 + n_steps - 1``) with the physics record P (pieces.record; its noise
    coefficients made for this h). ``bins`` = (a_lo, a_inv, x_lo, x_inv, v_lo, v_inv), ``out``
    = (hist_A, hist_x, hist_v, hist_joint, moments, events, stuck_time, energy, windows). Each
    path has its own generator state rng[b, p] and its own (x, v, xi) in state[b, p], both
    updated in place, so a run cut into any number of calls gives bit-identical results, for
    any thread count (one block per thread at a time: ``_block`` by ``_jit.over_blocks``). The
    docstring of ``_block`` says what is accumulated where."""
    over_blocks(_block, state.shape[0], rng, state, n_steps, step0, n_burn, stride, h, P, bins,
                out, spw)


@jit(nogil=True)
def _block(first, every, rng, state, n_steps, step0, n_burn, stride, h, P, bins, out, spw):
    """run_paths for the paths of blocks first, first + every, ... (``_jit.over_blocks`` runs
    one such call per thread; compiled ``nogil``), LANES paths of a block at a time in lanes
    (``lane_step``; the last group of a block runs as many lanes as it has paths).

    Steps with global index < ``n_burn`` are burn-in. After it, event counts (and, with
    ``energy``, the power balance) are accumulated every step, and every ``stride`` steps a
    sample is taken: histograms, moments, and with ``windows`` the per-path sum of A over
    windows of ``spw`` samples (windows[b, p, w]; the certificate's raw data). A sample with
    v == 0 exactly (the mass at rest: stuck, or resting on the wall) is the atom of p(x2) at 0
    and is counted in EV_ATOM, not in the x2 (or joint) bins. events[b, EV_TIME] counts the
    block's sampled path-steps (the caller multiplies by h).

    ``moments[b, p]``, ``energy[b, p]`` and ``stuck_time[b, p]`` (the time at rest: EV_STUCK
    of the block once summed by the caller) are per path: each path's float sums are taken in
    step order whatever the cut into calls and the grouping, so they too are bit-identical
    (per-block float sums, interleaving the paths of a block call by call, were not: issue
    11.5). The caller sums over paths. The block's event columns hold whole numbers, whose
    sums do not depend on the order.

    energy[b, p] columns (time integrals over the sampled time, Strang sub-flow by sub-flow):
    EN_INPUT the work of the noise (OU: f xi v, trapezoid over B; white: the kick's exact
    change of v^2/2), EN_DAMP (c2 x^2 - c1) v^2 [+ the exact kinetic energy each velocity-
    damping sub-flow removes], EN_FRICTION mu |v| (trapezoid over B),
    EN_IMPACT the kinetic energy lost at impacts, (1 - r^2) v^2 / 2 each, and v^2 / 2 when
    the chatter guard rests the mass."""
    a_lo, a_inv, x_lo, x_inv, v_lo, v_inv = bins
    hist_A, hist_x, hist_v, hist_joint, moments, events, stuck_time, energy, windows = out
    w0sq, alpha, khi = P.w0sq, P.alpha, P.khi
    half = 0.5 * h
    with_energy = energy.shape[2] > 0  # the power balance asked for (an empty array: not)
    n_paths = state.shape[1]
    F, S = scratch()
    for b in range(first, state.shape[0], every):  # this thread's blocks
        for p0 in range(0, n_paths, LANES):
            m = min(LANES, n_paths - p0)
            load(m, F, S, rng, state, stuck_time, b, p0)
            impacts = 0
            chatter = 0
            steps = 0
            left = -1  # steps until the next sample (a counter: no integer division per step)
            for n in range(step0, step0 + n_steps):
                imp, ch = lane_step(m, F, S, h, half, P, with_energy, n >= n_burn)
                if n < n_burn:
                    continue
                impacts += imp
                chatter += ch
                steps += m
                if left < 0:  # the first step after the burn-in in this call
                    left = (stride - (n - n_burn + 1) % stride) % stride
                sample = left == 0  # i.e. (n - n_burn + 1) % stride == 0
                left = stride - 1 if sample else left - 1
                if not with_energy and not sample:
                    continue
                for j in range(m):
                    p = p0 + j
                    x, v = F[L_X, j], F[L_V, j]
                    if with_energy:
                        # (a switched-off effect adds +0.0: the sums are unchanged, bit for bit)
                        energy[b, p, EN_DAMP] += F[L_DV1, j]
                        energy[b, p, EN_DAMP] += F[L_DV2, j]
                        e_in, e_damp, e_fric = noise_energy(
                            P, h, half, F[L_K, j], P.mu, F[L_VB, j], F[L_VC, j], F[L_VK, j],
                            F[L_VD, j], F[L_VE, j], F[L_XIU, j])
                        energy[b, p, EN_INPUT] += e_in
                        energy[b, p, EN_INPUT] += F[L_WP, j]  # the parametric noises' work
                        energy[b, p, EN_DAMP] += e_damp
                        energy[b, p, EN_FRICTION] += e_fric
                        energy[b, p, EN_IMPACT] += F[L_LOSS1, j]  # each wall's own law
                        energy[b, p, EN_IMPACT] += F[L_LOSS2, j]
                    if not sample:
                        continue
                    events[b, EV_SAMPLES] += 1.0
                    A = amplitude_general(x, v, w0sq, alpha, khi)
                    if windows.shape[2] > 0:
                        w = ((n - n_burn + 1) // stride - 1) // spw
                        if w < windows.shape[2]:
                            windows[b, p, w] += A
                    if hist_A.shape[1] > 0:
                        i = math.floor((A - a_lo) * a_inv)
                        if 0 <= i < hist_A.shape[1]:
                            hist_A[b, i] += 1.0
                        else:
                            events[b, EV_OUT_A] += 1.0
                    ix = -1
                    iv = -1
                    if hist_x.shape[1] > 0 or hist_joint.shape[1] > 0:
                        ix = math.floor((x - x_lo) * x_inv)
                    if hist_v.shape[1] > 0 or hist_joint.shape[1] > 0:
                        iv = math.floor((v - v_lo) * v_inv)
                        if v == 0.0:
                            iv = -2
                            events[b, EV_ATOM] += 1.0
                    if hist_x.shape[1] > 0:
                        if 0 <= ix < hist_x.shape[1]:
                            hist_x[b, ix] += 1.0
                        else:
                            events[b, EV_OUT_X] += 1.0
                    if hist_v.shape[1] > 0:
                        if 0 <= iv < hist_v.shape[1]:
                            hist_v[b, iv] += 1.0
                        elif iv != -2:
                            events[b, EV_OUT_V] += 1.0
                    if hist_joint.shape[1] > 0:
                        if 0 <= ix < hist_joint.shape[1] and 0 <= iv < hist_joint.shape[2]:
                            hist_joint[b, ix, iv] += 1.0
                    if moments.shape[2] > 0:
                        moments[b, p, MO_A] += A
                        moments[b, p, MO_A2] += A * A
                        moments[b, p, MO_X] += x
                        moments[b, p, MO_X2] += x * x
                        moments[b, p, MO_V] += v
                        moments[b, p, MO_V2] += v * v
                        moments[b, p, MO_MAXA] = max(moments[b, p, MO_MAXA], A)
                        moments[b, p, MO_MAXX] = max(moments[b, p, MO_MAXX], abs(x))
                        moments[b, p, MO_MAXV] = max(moments[b, p, MO_MAXV], abs(v))
            events[b, EV_IMPACTS] += impacts
            events[b, EV_CHATTER] += chatter
            events[b, EV_TIME] += steps
            store(m, F, S, rng, state, stuck_time, b, p0)
