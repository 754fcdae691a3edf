"""vifpk.physics.spring (U, g, A(E) written once) and the noise kinds' averaging pieces."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vifpk.physics import spring

SPRINGS = [(1.69, 0.6), (1.0,), (0.0, 2.0), (1.0, 0.6, 0.05, 0.01), (2.0, 0.0, 0.3)]


@pytest.mark.parametrize("k", SPRINGS)
def test_potential_and_restoring_against_the_power_sum(k):
    # independent form: U = sum_j k_{2j-1} x^{2j} / (2j) term by term, g its derivative
    x = np.linspace(-2.5, 2.5, 41)
    U = sum(c * x ** (2 * j + 2) / (2 * j + 2) for j, c in enumerate(k))
    g = sum(c * x ** (2 * j + 1) for j, c in enumerate(k))
    gp = sum((2 * j + 1) * c * x ** (2 * j) for j, c in enumerate(k))
    np.testing.assert_allclose(spring.potential(x, k), U, rtol=1e-14, atol=1e-300)
    np.testing.assert_allclose(spring.restoring(x, k), g, rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(spring.restoring_slope(x, k), gp, rtol=1e-14, atol=1e-300)
    # scalars give the array's numbers
    assert spring.potential(1.3, k) == spring.potential(np.array([1.3]), k)[0]


@pytest.mark.parametrize("k", SPRINGS)
def test_amplitude_inverts_the_potential(k):
    E = np.array([0.0, 1e-8, 0.01, 0.7, 5.0, 300.0])
    A = spring.amplitude_of_energy(E, k)
    assert A[0] == 0.0 and np.all(A >= 0)
    np.testing.assert_allclose(spring.potential(A, k), E, rtol=4e-15, atol=0)
    # the scalar form (numba's) is the same algorithm: the same numbers
    np.testing.assert_allclose([spring.amplitude_scalar(float(e), k) for e in E], A,
                               rtol=2e-16, atol=0)


def test_turning_points_are_the_walls_inside_the_orbit():
    A = np.array([0.1, 0.5, 2.0])
    lo, hi = spring.turning_points(A, -0.3, 0.8)
    np.testing.assert_array_equal(lo, [-0.1, -0.3, -0.3])
    np.testing.assert_array_equal(hi, [0.1, 0.5, 0.8])
    lo, hi = spring.turning_points(A, -math.inf, math.inf)
    np.testing.assert_array_equal(lo, -A)
    np.testing.assert_array_equal(hi, A)


def test_noise_kinds_declare_their_spectra_and_refuse_what_they_lack():
    from vifpk.averaging.noise import Spectrum

    from vifpk.physics import noise

    ou = Spectrum.of("ou", D=0.02, alpha1=0.7)
    w = np.array([0.0, 0.5, 3.0])
    np.testing.assert_allclose(ou(w), 0.02 / (math.pi * (w**2 + 0.49)), rtol=1e-15)
    c, a2 = ou.rational_parts()
    np.testing.assert_allclose(w**2 * ou(w), c - a2 * ou(w), rtol=1e-14)
    assert not ou.flat and ou.correlation_rate() == 0.7
    white = Spectrum.of("white", D=0.02)
    assert white.flat and white.level() == 0.02 / math.pi and white.correlation_rate() is None
    np.testing.assert_array_equal(white(w), 0.02 / math.pi)
    with pytest.raises(ValueError, match="'white' declares no rational_parts"):
        white.rational_parts()
    with pytest.raises(noise.NoPiece, match="noise kind must be one of .*, not 'harmonic'"):
        noise.pieces("harmonic", "averaging")


@pytest.mark.slow
def test_numba_compiles_the_same_source():
    numba = pytest.importorskip("numba")
    # the Monte Carlo compiles potential_parts (montecarlo/geometry.py); U(x, k) on it
    P = numba.njit(spring.make_potential(numba.njit(spring.potential_parts)))
    G = numba.njit(spring.restoring)
    A = numba.njit(spring.make_amplitude_scalar(P, G))
    for k in ((1.69, 0.6), (1.0, 0.6, 0.05, 0.01)):
        ka = np.array(k)
        for x in (0.3, 1.7):
            assert P(x, ka) == spring.potential(x, k)
            assert G(x, ka) == spring.restoring(x, k)
            E = spring.potential(x, k)
            assert A(E, ka) == spring.amplitude_scalar(E, k)


def test_the_averaged_models_decide_nothing_by_a_kind_or_law_name():
    # issue 37: a kind or law is one module; no branch on its name in averaging/ or fpk/
    import re
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    pattern = re.compile(r"\b(kind|law)\s*[!=]=|alpha1 is None")
    bad = [f"{p.relative_to(root)}:{i}" for d in ("averaging", "fpk")
           for p in sorted((root / d).rglob("*.py"))
           for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
           if pattern.search(line)]
    assert not bad, bad
