"""Walls anywhere in the Monte Carlo of the original system (issue 37), against truths that need
no vifpk code: the Gibbs law between two elastic walls, the wall-free system when the walls are
out of reach, and the energy balance with lossy walls of each impact law.

Slow tier: the kernel is specialised per walls' record class (about 12 s of numba compiling from a
cold cache each), so every test here with two walls uses the one pair of laws (lower: Newton,
upper: Johnson); the wall-free comparison run is the kernel test_montecarlo's Gibbs test and
test_transient_mc compile anyway. Each then runs about a second.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad
from vifpk.montecarlo.simulate import Settings, simulate

from vifpk.core.scene import scene_from_dict

pytestmark = pytest.mark.slow

# x'' + d0 x' + x + 0.6 x^3 = W, E[W W] = 2 D delta: temperature T = D f^2 / d0 = 0.25
D0, D, ALPHA = 0.2, 0.05, 0.6
T = D / D0
SYSTEM = {"c1": -D0, "c2": 0.0, "omega0": 1.0, "alpha": ALPHA, "mu": 0.0, "f": 1.0}
A_LO, B_UP = -0.5, 0.7
EX = np.linspace(A_LO, B_UP, 25)
EV = np.linspace(-2.0, 2.0, 25)


def _scene(**walls):
    return scene_from_dict({"system": {**SYSTEM, **walls}, "noise": {"kind": "white", "D": D}})


def _run(sc, *, time=400.0, seed=3, edges_x=EX, obs=("x1", "x2", "energy", "events")):
    st = Settings(paths=256, blocks=16, dt=0.01, time=time, burn_in=30.0, seed=seed, bins=24,
                  threads=1, floor=0.0, budget=0.0, sample_every=0.5, progress=False,
                  certificate=False, observables=obs,
                  edges={"edges_A": np.linspace(0.0, 3.0, 25), "edges_x": edges_x,
                         "edges_v": EV})
    return simulate(sc.system, sc.noise, st)


def _U(x):
    return 0.5 * x * x + 0.25 * ALPHA * x ** 4


def _bin_means(density, edges):
    """The density's mean over each bin, by quadrature."""
    return np.array([quad(density, edges[i], edges[i + 1])[0] / (edges[i + 1] - edges[i])
                     for i in range(edges.size - 1)])


def test_elastic_walls_on_both_sides_give_the_gibbs_law():
    """r = 1 at both walls conserves H = v^2/2 + U(x) at impacts, so the stationary law is
    Gibbs on a <= x <= b: p(x, v) ~ exp(-d0 H / (D f^2)), p(x1) ~ exp(-U/T) on [a, b] and
    p(x2) the normal law N(0, T). The MC's L1 distance to each (bin means by quadrature) within
    3x its own L1 noise floor (sum of sqrt(2/pi) x the bin standard errors x widths: the
    expected L1 of pure noise). Measured: 0.88 and 1.37 floors (seed 3). The upper wall obeys
    Johnson's law with r = 1 and a yield speed of 1000 (2000 velocity standard deviations
    sqrt(T) = 0.5: never reached), where e(v) = r min(1, (v_yield / |v|)^(1/4)) is 1 exactly:
    elastic, and the kernel is the one of the other two-wall tests here (Newton below, Johnson
    above) instead of a Newton-Newton specialisation of its own."""
    res = _run(_scene(lower_wall={"at": A_LO, "r": 1.0},
                      upper_wall={"at": B_UP, "r": 1.0, "law": "johnson", "v_yield": 1000.0}))
    zx = quad(lambda x: math.exp(-_U(x) / T), A_LO, B_UP)[0]
    px = _bin_means(lambda x: math.exp(-_U(x) / T) / zx, EX)
    pv = _bin_means(lambda v: math.exp(-v * v / (2 * T)) / math.sqrt(2 * math.pi * T), EV)
    for key, ref, edges in (("x1", px, EX), ("x2", pv, EV)):
        l1 = float(np.sum(np.abs(res.data[key]["p"] - ref) * np.diff(edges)))
        assert l1 < 3 * res.info["L1_floor"][key], (key, l1, res.info["L1_floor"][key])
    assert res.info["events"]["impacts_per_time"]["value"] > 0.05  # the walls are hit
    assert res.info["events"]["outside_fraction"]["x1"] == 0.0  # x stays in [a, b]


def test_walls_out_of_reach_are_the_wall_free_system_bit_for_bit():
    """Walls at -50 and 50 are never hit at T = 0.25: the kernel's arithmetic is then the
    wall-free kernel's (the drift's test fails, nothing else changes), bit for bit."""
    free = scene_from_dict({"system": {**SYSTEM, "barrier": False},
                            "noise": {"kind": "white", "D": D}})
    far = _scene(lower_wall={"at": -50.0, "r": 0.5}, upper_wall={"at": 50.0, "r": 0.5,
                                                                    "law": "johnson",
                                                                    "v_yield": 0.1})
    ex = np.linspace(-2.0, 2.0, 25)
    one, two = _run(free, time=100.0, edges_x=ex), _run(far, time=100.0, edges_x=ex)
    for key in ("x1", "x2"):
        assert np.array_equal(one.data[key]["p"], two.data[key]["p"])
    assert two.info["events"]["impacts_per_time"]["value"] == 0.0


@pytest.mark.parametrize("laws", [("newton", "johnson")])
def test_each_walls_loss_closes_the_energy_balance(laws):
    """Lossy walls, one of each law (lower: Newton, r = 0.8; upper: Johnson, r = 0.9 with yield
    speed 0.3, so most impacts are above yield): in the stationary state the power the white
    noise puts in, f^2 D exactly, equals the damping's d0 E[v^2] plus the walls' losses (each
    impact's (1 - e(v)^2) v^2 / 2 by its own law). The kernel's counted balance (block means)
    closes within 3 standard errors, and the counted losses agree with the exact input within 3
    standard errors: a wall whose loss were not counted (or counted with another e(v) than its
    reflection used) would leave the impacts' share, here ~30% of the input, unbalanced.
    Measured: input 0.04964 +- 0.00041 (exact 0.05), damping 0.03502, impacts 0.01463,
    residual -7.7e-6 +- 1.6e-5."""
    lo, up = laws
    sc = _scene(lower_wall={"at": -0.4, "r": 0.8, "law": lo},
                upper_wall={"at": 0.6, "r": 0.9, "law": up, "v_yield": 0.3})
    res = _run(sc, time=400.0, edges_x=np.linspace(-0.4, 0.6, 25))
    en = res.data.get("energy") or res.info["energy"]
    assert en["impacts"]["value"] > 0.2 * en["input_exact"]
    assert abs(en["residual"]["value"]) < 3 * en["residual"]["err"], en
    assert abs(en["losses"]["value"] - en["input_exact"]) < 3 * en["losses"]["err"], en


def test_orbit_starts_between_walls_are_the_free_orbit_conditioned_on_them():
    """First passage, transients and splitting start on the conservative orbit at a phase
    uniform in time; between walls at a = -0.3 and b = 0.5 that is the elastic orbit truncated
    at them, i.e. the free orbit's law conditioned on [a, b]. Linear spring, amplitude 1:
    x = cos(theta), theta uniform, so F(x) = 1 - arccos(x) / pi, conditioned on [a, b]; every
    start has energy U(1) = 1/2 exactly (to rounding); Kolmogorov-Smirnov distance of 4000
    starts below 1.95 / sqrt(n) (the 0.1% critical value)."""
    from vifpk.montecarlo.passage import sample_starts

    a, b = -0.3, 0.5
    sc = scene_from_dict({"system": {"c1": -0.1, "c2": 0.0, "omega0": 1.0, "alpha": 0.0,
                                     "mu": 0.0, "f": 1.0, "lower_wall": {"at": a, "r": 0.9},
                                     "upper_wall": {"at": b, "r": 0.9}},
                          "noise": {"kind": "white", "D": 0.01}})
    n = 4000
    s = sample_starts(sc.system, sc.noise, amplitude=1.0, n=n, seed=5)
    x, v = s[:, 0], s[:, 1]
    assert np.all((x >= a) & (x <= b))
    assert np.allclose(0.5 * v * v + 0.5 * x * x, 0.5, rtol=0, atol=1e-12)

    def F(y):
        return 1.0 - np.arccos(y) / np.pi

    xs = np.sort(x)
    cdf = (F(xs) - F(a)) / (F(b) - F(a))
    ks = max(np.max(np.arange(1, n + 1) / n - cdf), np.max(cdf - np.arange(n) / n))
    assert ks < 1.95 / math.sqrt(n), ks


def test_a_lower_wall_tending_to_zero_gives_the_papers_system():
    """A lower wall at -1e-9 (Newton, the paper's r) against the paper's wall at 0, same seed:
    the same record class (no new compilation), so the only differences are the wall's offset
    and g(a) ~ -1e-9 in the chatter guard, and the starts (the fold for the wall at 0, a clip
    for the other), whose memory the 300 time units of burn-in erase; the paths then diverge,
    so the runs are effectively independent: p(A) within 3x the two runs' noise floors added.
    Measured: L1 0.082 against floors 0.045 + 0.043 (seed 2), 0.076 against 0.054 + 0.056."""
    from vifpk.core.scene import load_scene

    base = load_scene("paper-base")
    near = base.with_values({"system.lower_wall.at": -1e-9})
    ea = np.linspace(0.0, 2.5, 26)
    st = Settings(paths=64, blocks=8, dt=0.01, time=600.0, burn_in=300.0, seed=2, bins=25,
                  threads=1, floor=0.0, budget=0.0, sample_every=0.5, progress=False,
                  certificate=False, observables=("A",),
                  edges={"edges_A": ea, "edges_x": np.linspace(-2.5, 2.5, 26),
                         "edges_v": np.linspace(-3.0, 3.0, 26)})
    one = simulate(base.system, base.noise, st)
    two = simulate(near.system, near.noise, st)
    l1 = float(np.sum(np.abs(one.data["A"]["p"] - two.data["A"]["p"]) * np.diff(ea)))
    assert l1 < 3 * (one.info["L1_floor"]["A"] + two.info["L1_floor"]["A"]), l1
