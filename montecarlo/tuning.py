"""Defaults from the physics: the burn-in from a measured relaxation time, dt from a target.

**Relaxation time (for ``burn_in = "auto"``).** A pilot runs pairs of paths, one started near
rest and one at the largest amplitude a first pilot saw, each pair driven by the *same*
random numbers (common random numbers: the difference of the pair carries no noise of its
own at the start). The mean difference d(t) of their amplitudes over the pairs decays with the
slowest relaxation of the amplitude; tau is the negative inverse slope of log d(t), fitted
over the windows where d is above 3 standard errors, after d has fallen by e (so that faster
modes are gone). The Monte Carlo measures this itself, so the ground truth does not lean on
the averaged models whose error it judges. The burn-in is ``BURN_FACTOR`` = 6 tau: the start
leaves e^-6 = 2.5e-3 of its offset at the first sample, and tau / time of that in the time
averages. The certificate (certificate.py) still checks the result.

**Time step (for ``dt = "auto"``).** The bias model is the envelope of the scheme's measured
bias curves on unlike scenes (issue 44; benchmarks/bench_dt_bias.py,
benchmarks/results/dt_bias.json, ``python benchmarks/bench_dt_bias.py --envelope``): the L1
bias of p(A) against a fine step on a dt ladder, on paper-base and six scenes unlike it (a
stiffer spring, white noise, r = 0.5, mu = 0.05, omega0 = 2, positive damping) and the shipped
systems/quintic, each read in the dimensionless step Omega dt (below). Where the rule works
(Omega dt <= 0.125; floors 0.005 to 0.02 put it at 0.028-0.046) the curves fall with local
orders 1.5-2.6 toward small steps, and the largest bias at a given Omega dt is the friction
scene's (mu = 0.05: 28% of the time stuck): b = C (Omega dt)^p with p = 1.5, the least local
order measured (mu = 0.05 between Omega dt 0.05 and 0.1; the model then never falls faster
than a measured curve), and C = 0.526, the largest b / (Omega dt)^p of the resolved points (mu
= 0.05 at 0.05 and at 0.1, 0.524 and 0.526); a point counts as resolved at twice the pair's
noise floor. Written in the base scene's step (Omega dt / OMEGA_REF, as the rule has read it
since issue 29): L1 bias = BIAS_C dt^BIAS_P with BIAS_C = 0.526 OMEGA_REF^1.5 = 0.64, BIAS_P =
1.5. (The fit before, 0.173 dt^1.11, was made on paper-base alone; that scene's bias is a
third of the envelope at Omega dt 0.05 -- 0.0017 at dt 0.0217, 0.0015 at 0.0417 in the issue's
measurement -- so doubling its step would have held there and not on mu = 0.05, whose bias at
Omega dt 0.05 is 0.006, against the allowance 0.0025 at floor 0.005.)

A step is only large or small against the scene's own time scale: the scene with every
frequency multiplied by s (t -> t / s: k1 -> s^2 k1, k3 -> s^2 k3, c1, c2 -> s c1, s c2, mu ->
s^2 mu, alpha1 -> s alpha1, f^2 D -> s^3 f^2 D) has the same p(A), and the same scheme run at
h / s follows its paths step for step, so its bias at h / s is the base one's at h. The model
is therefore read in a dimensionless step Omega dt, Omega a frequency of the scene:
bias = C (Omega dt / OMEGA_REF)^p, and ``auto_dt(F)`` is the largest dt whose predicted bias is
``BIAS_FRACTION`` = 1/2 of the target floor F (combined error sqrt(1 + 1/4) F = 1.12 F):
dt = dt_ref(F) OMEGA_REF / Omega, dt_ref(F) clipped to DT_RANGE = [0.0025, 0.04] (the OU
update is exact for any dt, so the noise's correlation time sets no limit). Omega
(``scene_omega``) is the fastest free conservative orbit (orbit_omega: 2 pi / T(A)) on
amplitudes up to the median over the scale pilot's paths of each path's largest amplitude:
the orbits the paths reach, sqrt(k1) for a softening spring, the orbit at that amplitude for
a hardening one (and defined without a linear term). Before the pilot has run the step is
provisional (auto_dt without an amplitude). The paper's base scene gets 0.5 / 21 at floor
0.005 (0.5 / 23 before; 0.5 / 20 for the pilots' smallest amplitudes over seeds) and 0.5 / 13
at 0.01, as before.

At the same Omega the bias differs by up to 10x between scenes, with how strongly p(A)
answers a small change in the energy balance (friction's stick-slip and a strongly inelastic
wall are first order in dt), which no quantity of the scene gives before a run; the envelope
is the largest measured. So the rule is checked at run time (``step_check`` below, on by
default with dt "auto": an independent run at CHECK_FACTOR x dt) and the run says when the
check fails; and it is checked on shipped scenes that were not in the fit
(stepcheck.held_out_bias: tests/test_dt_heldout.py, benchmarks/bench_dt_heldout.py).

**Parametric noise** (issue 37). A parametric noise has a time scale of its own: by Ito's
formula on H (docs/averaging.md section 12) it spreads the energy at the relative rate
nu = sigma_par^2 / E^2, sigma_par^2 = 2 D_k <g^2 v^2> + 2 D_c <d^2 v^4> (parametric_rate), a
frequency (it scales as s under the clock change above), so the dimensionless step has a
second part, nu dt. The scheme's sub-flows of the parametric noises are exact with x frozen
over half a step (docs/montecarlo.md), so what the step must resolve is the change of the
energy they make over it: its relative variance is nu dt, against Omega dt of the orbit's turn
per step. The fitted bias C (Omega dt)^p holds for nu <= Omega (the base family: no
parametric noise); for nu > Omega the energy's random change per step is the larger one and
the rule reads the bias in the faster rate: Omega -> max(Omega, nu) (scene_rate), nu the
largest over the same amplitudes. This is a bound by the faster scale, not a fit (no ladder of
steps was measured on parametric scenes); the run-time check (step_check) still judges the
step. On a mean-square-stable linear oscillator nu = D_k w^2 + 3 D_c k^2 < k + D_c k^2 (the
stability condition D_k w^2 + 2 D_c k^2 < k), so the rule changes nothing unless the damping
is strong (k of the order of w) or the damping noise is; on the paper's c2 x^2 x' damping the
damping noise's nu grows as A^4 with the amplitude the pilot reaches.

**Held noise** (issue 44). A kind whose velocity stage holds its force over the step (OU,
bounded noise: xi sampled once a step, at its middle) drives the orbit with a zero-order hold
of the sampled force, whose spectrum at the orbit frequency omega differs from S(omega) by the
aliases of the sampled sequence: relative error eps = sinc^2(omega h / 2) (h / 2 pi)
sum_k R(k h) cos(omega k h) / S(omega) - 1, about (rate h)^2 / 12 for a spectrum falling as
w^-2 beyond the kind's rate (OU: (alpha1 h)^2 / 12 to that order; bounded noise about
(sigma^2 h / 2)^2 / 12, and its centre frequency's aliases where Omega h is not small). The
kind declares eps (MonteCarloNoise.held_excess, its own closed form: no list of kinds here);
the rule reads it over the orbit frequencies the pilot's amplitudes span and bounds the bias
of p(A) by HOLD_SENSITIVITY x |eps| (a linear oscillator: 2 / e |eps|). The envelope's curves
were measured with an OU noise at alpha1 = 2 (all but white's), so they hold its
(2 dt)^2 / 12 already; what a scene's noise makes beyond that is added to the envelope (two
errors of p(A): at most their sum in L1), and the step is the largest whose sum is within
BIAS_FRACTION x F (predicted_bias). The shipped noises (OU alpha1 = 2: nothing beyond;
bounded sigma = 2: 1e-5) leave every shipped step as it was; a fast noise is where it binds:
linear-ou at alpha1 = 20 (bench_dt_bias.py fast-ou) measured 0.227, 0.072, 0.021 at dt 0.1,
0.05, 0.025 against the model's 0.33, 0.087, 0.023.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import Any

import numpy as np

from vifpk.core.defaults import BURN_FACTOR  # noqa: F401  (re-exported; its one home)

#: L1 bias = BIAS_C (Omega dt / OMEGA_REF)^BIAS_P: the envelope of the measured curves (module)
BIAS_C, BIAS_P = 0.64, 1.5
BIAS_FRACTION = 0.5
DT_RANGE = (0.0025, 0.04)  # the base family's range of dt; OMEGA_REF x it: the range of Omega dt
#: the unit of Omega dt in which BIAS_C is written: Omega of the base scene (paper-base),
#: scene_omega at the median of its scale pilot's path maxima, 1.115-1.145 over 32 seeds
#: (mean 1.131, sd 0.008; 1.144 at the default seed)
OMEGA_REF = 1.14
DEFAULT_FLOOR = 0.01  # the floor dt "auto" aims at when no target is given
AMPLITUDE_NODES = 16  # amplitudes at which Omega looks for the fastest orbit
#: the range of the base scene's pilot amplitude over seeds (tests: the base keeps its step)
BASE_AMPLITUDES = (0.7656, 0.8346)


def orbit_omega(phys: dict[str, Any], A: float, nodes: int = 64) -> float:
    """Angular frequency 2 pi / T(A) of the free conservative orbit of amplitude A (no wall,
    no damping, no noise): T(A) = 4 int_0^A dx / sqrt(2 (U(A) - U(x))), U the spring's
    potential, by Gauss-Legendre in x = A sin(theta) (the integrand is then smooth); sqrt(k1)
    at A = 0."""
    k = _spring(phys)
    if not A > 0:
        return math.sqrt(max(k[0], 0.0))

    def U(x: Any) -> Any:
        return sum(c * x ** (2 * i + 2) / (2 * i + 2) for i, c in enumerate(k))

    th, wq = _nodes(nodes)
    du = np.maximum(U(A) - U(A * np.sin(th)), 1e-300)
    T = math.pi * float(np.sum(wq * A * np.cos(th) / np.sqrt(2.0 * du)))
    return 2.0 * math.pi / T


@lru_cache(maxsize=4)
def _nodes(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes mapped to theta in (0, pi / 2), and their weights."""
    t, w = np.polynomial.legendre.leggauss(n)
    return 0.25 * math.pi * (t + 1.0), w


def scene_omega(phys: dict[str, Any], amplitude: float) -> float:
    """Omega: the fastest free orbit on amplitudes 0..amplitude, max_j orbit_omega(amplitude
    j / n) over n = AMPLITUDE_NODES (orbit_omega(0) = sqrt(k1)): sqrt(k1) for a softening
    spring, the orbit at ``amplitude`` for a hardening one."""
    return max(orbit_omega(phys, amplitude * j / AMPLITUDE_NODES)
               for j in range(AMPLITUDE_NODES + 1))


def parametric_rate(phys: dict[str, Any], A: float, nodes: int = 64) -> float:
    """nu(A): the rate at which the parametric noises alone spread the energy, relative to
    itself, on the free conservative orbit of amplitude A (walls ignored):
    nu = sigma_par^2 / E^2 with sigma_par^2 = 2 D_k <g^2 v^2> + 2 D_c <d^2 v^4> (Ito's formula
    on H, docs/averaging.md section 12), the orbit average by Gauss-Legendre in x = A sin(theta)
    as in orbit_omega. 0 without parametric noise or at A = 0. A frequency: under t -> t / s
    (g -> s^2 g, d -> s d, D_k, D_c -> D_k / s, D_c / s, E -> s^2 E) it scales as s. The linear
    oscillator: nu = D_k w^2 + 3 D_c k^2."""
    D_k, D_c = phys.get("D_k") or 0.0, phys.get("D_c") or 0.0
    if not (D_k > 0 or D_c > 0) or not A > 0:
        return 0.0
    k = _spring(phys)
    d = (-float(phys["c1"]), float(phys["c2"]),
         *(() if phys.get("dhi") is None else (float(c) for c in phys["dhi"])))

    def U(x: Any) -> Any:
        return sum(c * x ** (2 * i + 2) / (2 * i + 2) for i, c in enumerate(k))

    th, wq = _nodes(nodes)
    x = A * np.sin(th)
    E = U(A)
    v2 = np.maximum(2.0 * (E - U(x)), 1e-300)
    g = sum(c * x ** (2 * i + 1) for i, c in enumerate(k))
    dd = sum(c * x ** (2 * i) for i, c in enumerate(d))
    w = wq * np.cos(th) / np.sqrt(v2)  # dt = dx / v, dx = A cos(theta) d theta
    s2 = (2 * D_k * g * g * v2 + 2 * D_c * dd * dd * v2 * v2) @ w / np.sum(w)
    return float(s2 / (E * E)) if E > 0 else 0.0


def scene_rate(phys: dict[str, Any], amplitude: float) -> float:
    """The fastest rate of the scene on amplitudes 0..amplitude: max(scene_omega, the largest
    parametric_rate at amplitude j / n, j = 1..n); scene_omega itself without parametric
    noise."""
    omega = scene_omega(phys, amplitude)
    if not (phys.get("D_k") or phys.get("D_c")):
        return omega
    nu = max(parametric_rate(phys, amplitude * j / AMPLITUDE_NODES)
             for j in range(1, AMPLITUDE_NODES + 1))
    return max(omega, nu)


#: the L1 change of p(A) per relative change of the input spectrum at the orbit frequencies:
#: 2 / e = 0.74 for the linear oscillator (Rayleigh p(A), E[A^2] proportional to the input;
#: L1 = eps int |u - 1| e^-u du), rounded up (hold_bias)
HOLD_SENSITIVITY = 1.0


def orbit_omegas(phys: dict[str, Any], amplitude: float | None) -> list[float]:
    """The free orbits' frequencies on amplitudes 0..amplitude (the AMPLITUDE_NODES + 1 of
    scene_omega); sqrt(k1) alone without an amplitude."""
    if amplitude is None or not (amplitude > 0 and math.isfinite(amplitude)):
        return [orbit_omega(phys, 0.0)]
    return [orbit_omega(phys, amplitude * j / AMPLITUDE_NODES)
            for j in range(AMPLITUDE_NODES + 1)]


def hold_bias(phys: dict[str, Any], omegas: list[float], dt: float) -> float:
    """The bias of p(A) the held noise force makes at step dt: HOLD_SENSITIVITY x the largest
    |held_excess(params, omega, dt)| over the orbit frequencies ``omegas``, the relative
    error of the held force's spectrum declared by the noise kind (vifpk.core.protocols.
    MonteCarloNoise.held_excess: about (rate dt)^2 / 12, rate the kind's correlation rate:
    OU's alpha1, bounded noise's sigma^2 / 2); 0 for a kind that declares none (exact in law
    over a step: white) or a phys without a noise (the rule's unit tests)."""
    noise = phys.get("noise")
    if noise is None or not omegas:
        return 0.0
    from vifpk.physics import noise as noise_kinds
    held = noise_kinds.pieces(noise.kind, "montecarlo").held_excess
    if held is None:
        return 0.0
    # an orbit of frequency 0 (a pure cubic spring at A = 0, the provisional rate before the
    # pilot) has no held-force error to read: the envelope's term stands alone there
    return HOLD_SENSITIVITY * max((abs(held(noise.values, w, dt)) for w in omegas if w > 0),
                                  default=0.0)


#: the fitted scenes' noise (OU, alpha1 = 2: every curve of the envelope but white's): its
#: held force's error, (FIT_NOISE_RATE dt)^2 / 12, is inside the measured envelope already
FIT_NOISE_RATE = 2.0


def _extra_hold(phys: dict[str, Any], omegas: list[float], dt: float) -> float:
    """The held noise's bias beyond what the envelope's own curves held: hold_bias less
    HOLD_SENSITIVITY (FIT_NOISE_RATE dt)^2 / 12, at least 0."""
    fit = HOLD_SENSITIVITY * (FIT_NOISE_RATE * dt) ** 2 / 12.0
    return max(hold_bias(phys, omegas, dt) - fit, 0.0)


def _rate(phys: dict[str, Any], amplitude: float | None) -> float:
    if amplitude is None or not (amplitude > 0 and math.isfinite(amplitude)):
        return max(math.sqrt(max(phys["w0sq"], 0.0)), 1.0) * OMEGA_REF
    return scene_rate(phys, amplitude)


def predicted_bias(phys: dict[str, Any], amplitude: float | None, dt: float) -> float:
    """The step rule's model of the L1 bias of p(A) at step dt (module docstring; the one the
    rule and a request's check read): the scheme's envelope BIAS_C (rate dt /
    OMEGA_REF)^BIAS_P, rate = scene_rate (max(sqrt(k1), 1) OMEGA_REF without an amplitude,
    the provisional rule's), plus the held noise force's bias beyond the one the envelope's
    curves held (their OU noise at alpha1 = FIT_NOISE_RATE): two errors of p(A), so at most
    their sum in L1 (the triangle inequality)."""
    env = BIAS_C * (_rate(phys, amplitude) * dt / OMEGA_REF) ** BIAS_P
    return env + _extra_hold(phys, orbit_omegas(phys, amplitude), dt)


def _hold_limit(phys: dict[str, Any], amplitude: float | None, dt: float, allowed: float
                ) -> float:
    """dt, or the largest step below it whose predicted_bias is within ``allowed``
    (bisection in log dt; both parts grow with dt)."""
    omegas = orbit_omegas(phys, amplitude)
    if _extra_hold(phys, omegas, dt) <= 0.0:
        return dt
    lo, hi = dt * 1e-6, dt
    for _ in range(60):
        mid = math.sqrt(lo * hi)
        lo, hi = (mid, hi) if predicted_bias(phys, amplitude, mid) <= allowed else (lo, mid)
        if hi / lo < 1 + 1e-6:
            break
    return lo


def auto_dt(target_floor: float | None, phys: dict[str, Any],
            amplitude: float | None = None) -> float:
    """Largest dt whose predicted bias C (Omega dt / OMEGA_REF)^p is at most BIAS_FRACTION x
    the target floor F: dt = dt_ref OMEGA_REF / Omega, dt_ref = (BIAS_FRACTION F / C)^(1/p)
    within DT_RANGE (the base family's step for F; C, p = BIAS_C, BIAS_P), Omega =
    scene_omega(phys, amplitude) (see module). ``amplitude``: the median over the scale
    pilot's paths of each one's largest amplitude (simulate.py). Without it (before the
    pilot) the step is provisional, the scale pilot's own and the plan's estimate:
    dt_ref / max(sqrt(k1), 1), the base family's, shorter for a faster linear spring (the
    pilot is cheap: it errs short). With parametric noise Omega is scene_rate's max(Omega,
    nu): see the module's "Parametric noise". Then shortened, if need be, until the held
    noise force's bias (hold_bias) is within the same allowance: see "Held noise"."""
    F = target_floor if target_floor and target_floor > 0 else DEFAULT_FLOOR
    dt_ref = (BIAS_FRACTION * F / BIAS_C) ** (1.0 / BIAS_P)
    dt_ref = min(max(dt_ref, DT_RANGE[0]), DT_RANGE[1])
    if amplitude is None or not (amplitude > 0 and math.isfinite(amplitude)):
        dt = dt_ref / max(math.sqrt(max(phys["w0sq"], 0.0)), 1.0)
    else:
        dt = dt_ref * OMEGA_REF / scene_rate(phys, amplitude)
    return float(_hold_limit(phys, amplitude, dt, BIAS_FRACTION * F))


def fit_relaxation(t: np.ndarray, d: np.ndarray, se: np.ndarray) -> dict[str, Any]:
    """tau from the decay of d(t) (see module); returns tau and how it was found."""
    sig = d > 3 * se
    if not sig.any():
        return {"tau": float(t[0]), "method": "no significant offset at the first window"}
    d0 = d[0]
    below = np.nonzero(~sig)[0]
    last = int(below[0]) if below.size else t.size  # first window lost in the noise
    after = np.nonzero(d[:last] < d0 / math.e)[0]
    lo = int(after[0]) if after.size else 0
    idx = np.arange(lo, last)
    if idx.size >= 3:
        slope = np.polyfit(t[idx], np.log(d[idx]), 1)[0]
        if slope < 0:
            return {"tau": float(-1.0 / slope), "method": "fit of log d(t)",
                    "fit_windows": int(idx.size)}
    t_end = t[last - 1] if last > 0 else t[0]
    ratio = d0 / max(3 * float(se[last - 1]) if last > 0 else d0, 1e-300)
    tau = float(t_end / max(math.log(max(ratio, math.e)), 1.0))
    return {"tau": tau, "method": "time to reach the noise / log(offset / noise)"}



# --- the run-time check of dt = "auto" ---------------------------------------------------

CHECK_FACTOR = 4  # the check's step is CHECK_FACTOR x the run's
CHECK_FLOOR_RATIO = 2.0  # the check runs to this multiple of the run's floor (1/4 of its time)
#: the sequential check's looks (stepcheck.run_step_check): its coarse run's floor as these
#: multiples of the run's, each look about twice the sampled time of the one before, the last
#: CHECK_FLOOR_RATIO
CHECK_LOOKS = (2.0 * CHECK_FLOOR_RATIO, math.sqrt(2.0) * CHECK_FLOOR_RATIO, CHECK_FLOOR_RATIO)
#: the share of the target floor a run's start may leave in its sampled time's average, where
#: the burn-in ends at dt after a part at CHECK_FACTOR x dt (burnin._coarse_burn_in)
BURN_SHARE = 0.1
#: the share of the measured distance the check's start may leave in its first look
#: (stepcheck.run_step_check: its burn-in from where the run ended)
CHECK_START_SHARE = 0.05
CHECK_CONFIDENCE = 0.95
CHECK_ORDERS = (1.0, 2.0)  # the kernel's declared weak orders (kernels.WEAK_ORDER_*)
CHECK_MERGE = 5  # the check reads p(A) on bins of 5 neighbours (20 of the default 100)
CHECK_SPLITS = 64  # random half-splits of the blocks that measure the check's noise floor


def _l1(p: np.ndarray, q: np.ndarray, w: np.ndarray) -> float:
    return float(np.sum(np.abs(p - q) * w))


def _jackknife_l1(p_blocks: np.ndarray, q: np.ndarray, w: np.ndarray) -> float:
    """Delete-one-block jackknife standard error of L1(mean of p_blocks, q)."""
    n = p_blocks.shape[0]
    loo = (p_blocks.sum(axis=0) - p_blocks) / (n - 1)
    m = np.sum(np.abs(loo - q) * w, axis=1)
    return float(math.sqrt((n - 1) / n * np.sum((m - m.mean()) ** 2)))


def _coarse(d: dict[str, Any], w: np.ndarray, m: int) -> tuple[np.ndarray, np.ndarray,
                                                                  np.ndarray]:
    """(p, se, p_blocks) on bins of m neighbours (the mass per bin over its width; the
    standard error from the blocks' own coarse densities)."""
    n = (w.size // m) * m
    wc = w[:n].reshape(-1, m).sum(axis=1)
    blocks = np.asarray(d["p_blocks"], float)[:, :n]
    cb = (blocks * w[:n]).reshape(blocks.shape[0], -1, m).sum(axis=2) / wc
    return cb.mean(axis=0), cb.std(axis=0, ddof=1) / math.sqrt(cb.shape[0]), cb


def split_floor(blocks: np.ndarray, w: np.ndarray, splits: int = CHECK_SPLITS) -> float:
    """The L1 noise of a density that is the mean of ``blocks`` (i.i.d. batch densities),
    measured on them: half the mean L1 between the means of two random halves of the blocks
    (their difference has twice the standard deviation of the whole mean's error, and L1
    scales with it), over ``splits`` fixed random splits. Unlike sum_i sqrt(2/pi) se_i w_i it
    holds the noise that moves many bins together (a block whose paths sit higher shifts the
    whole histogram; compare.py), which is most of it where p(A) is narrow."""
    n = blocks.shape[0]
    rng = np.random.default_rng(0)
    out = 0.0
    for _ in range(splits):
        perm = rng.permutation(n)
        a, b = blocks[perm[: n // 2]].mean(axis=0), blocks[perm[n // 2: 2 * (n // 2)]].mean(axis=0)
        out += 0.5 * float(np.sum(np.abs(a - b) * w))
    return out / splits


def step_check(run: dict[str, Any], coarse: dict[str, Any], *, dt: float, factor: float,
               allowance: float, orders: tuple[float, float] = CHECK_ORDERS,
               merge: int = CHECK_MERGE, confidence: float = CHECK_CONFIDENCE
               ) -> dict[str, Any]:
    """Is the weak bias of p(A) at ``dt`` within ``allowance``? Judged from the run's p(A)
    (``run``: "p_blocks", "edges") and an independent run at the coarser step factor x dt
    (``coarse``, the same edges).

    If the bias of p(A) grows as b(h) = h^q beta(A), the two runs differ by the bias part
    L = (k^q - 1) b(dt) in L1 (k = factor), so b(dt) = L / (k^q - 1). The order q is not
    known for a scene; the kernel declares 1 across impacts and stick-slip and 2 on the
    smooth sub-system (``orders``, kernels.WEAK_ORDER_NONSMOOTH and WEAK_ORDER_SMOOTH), so
    L / (k^2 - 1) <= b(dt) <= L / (k - 1) (``bias_range``), and ``bias`` is the estimate at
    the rule's own order BIAS_P. L is read on bins of ``merge`` neighbours: the noise floor
    falls about sqrt(merge) times while the L1 of a smooth bias barely changes (and never
    grows: merging bins is a contraction in L1). It is estimated from the measured L1 with
    the noise floor F of the pair removed, L_hat = sqrt(max(L1^2 - F^2, 0)),
    F = sqrt(F_run^2 + F_check^2), each measured on its blocks (split_floor; at least the
    binwise sum_i sqrt(2/pi) sqrt(se_i^2 + se'_i^2) w_i of docs/montecarlo.md, "Error
    bars"), and sigma the delete-one-block jackknife of L1 over both runs' blocks; as in
    harness/workflows/tolerance.py, P(L <= tol) = Phi((sqrt(tol^2 + F^2) - L1) / sigma).
    Verdict: "passed" when P(L <= (k - 1) allowance) >= confidence (within the allowance
    even at order 1), "failed" when P(L > (k^2 - 1) allowance) >= confidence (beyond it even
    at order 2), else "undecided" (the order or the check's noise leaves it open).
    """
    from statistics import NormalDist

    w_fine = np.diff(np.asarray(run["edges"], float))
    p, se_p, blocks_p = _coarse(run, w_fine, merge)
    q, se_q, blocks_q = _coarse(coarse, w_fine, merge)
    n = (w_fine.size // merge) * merge
    w = w_fine[:n].reshape(-1, merge).sum(axis=1)
    L1 = _l1(p, q, w)
    bins_floor = float(np.sum(math.sqrt(2 / math.pi) * np.hypot(se_p, se_q) * w))
    floor = max(math.hypot(split_floor(blocks_p, w), split_floor(blocks_q, w)), bins_floor)
    sigma = math.hypot(_jackknife_l1(blocks_p, q, w), _jackknife_l1(blocks_q, p, w))
    lo_gain, hi_gain = (factor ** o - 1.0 for o in orders)
    gain = factor ** BIAS_P - 1.0
    z = NormalDist().inv_cdf(0.5 + confidence / 2)

    def est(x: float) -> float:
        return math.sqrt(max(x * x - floor * floor, 0.0))

    def below(tol: float) -> float:  # P(L <= tol)
        if sigma > 0:
            return NormalDist().cdf((math.hypot(tol, floor) - L1) / sigma)
        return float(L1 <= math.hypot(tol, floor))

    within = below(lo_gain * allowance)
    beyond = 1.0 - below(hi_gain * allowance)
    verdict = ("passed" if within >= confidence else "failed" if beyond >= confidence
               else "undecided")
    L = est(L1)
    return {"verdict": verdict, "dt": dt, "check_dt": factor * dt, "factor": factor,
            "orders": list(orders), "merge": merge, "allowance": allowance,
            "bias": L / gain, "bias_range": [L / hi_gain, L / lo_gain],
            "bias_interval": [est(L1 - z * sigma) / gain, est(L1 + z * sigma) / gain],
            "probability_within": within, "probability_beyond": beyond,
            "confidence": confidence, "L1": L1, "L1_floor": floor,
            "L1_floor_bins": bins_floor, "L1_err": sigma}


# --- time scales of a scene (the step rule's study, benchmarks/bench_dt_bias.py) ------------

def _spring(phys: dict[str, Any]) -> tuple[float, ...]:
    """(k1, k3, k5, ...) of g(x) = k1 x + k3 x^3 + ... from the kernel's arguments."""
    khi = phys.get("khi")
    return (float(phys["w0sq"]), float(phys["alpha"]),
            *(() if khi is None else (float(c) for c in khi)))


def scene_scales(phys: dict[str, Any], A: float) -> dict[str, float]:
    """Time scales of a scene at amplitude A: the free orbit's frequency (orbit_omega), the
    fastest local one sqrt(g'(A)), sqrt(k1), and the damping c2 A^2 - c1 (the step rule's
    study, benchmarks/bench_dt_bias.py)."""
    k = _spring(phys)
    stiff = sum((2 * i + 1) * c * A ** (2 * i) for i, c in enumerate(k))  # g'(A)
    return {"A": A, "omega_orbit": orbit_omega(phys, A), "omega_stiff": math.sqrt(max(stiff, 0.0)),
            "omega0": math.sqrt(max(k[0], 0.0)),
            "damping_at_A": float(phys["c2"] * A * A - phys["c1"])}
