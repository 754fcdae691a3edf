"""Parametric white noise (Stratonovich) in the exact model (issue 37; docs/averaging.md
section 12), against closed forms derived by hand for the linear oscillator

    x'' + 2 z w x' (1 + xi_c) + w^2 x (1 + xi_k) = f xi:

on its orbit <v^2> = E, <g^2> = w^2 E, <g^2 v^2> = w^2 E^2 / 2, <v^4> = 3 E^2 / 2, so
    m_E = -(2 z w - D_k w^2 - 8 D_c z^2 w^2) E + D f^2 = -a E + D f^2,
    sigma_E^2 = 2 D f^2 E + (D_k w^2 + 12 D_c z^2 w^2) E^2 = s E + b E^2,
and p(E) = C exp(int 2 m / sigma^2) / sigma^2 = C (s + b E)^(-2 a / b - 2) (partial fractions)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from vifpk.averaging.exact import ExactModel
from vifpk.averaging.noise import Spectrum
from vifpk.averaging.stationary import amplitude_density

W, Z, D, F = 1.3, 0.05, 0.02, 1.0


def linear(D_k=0.0, D_c=0.0):
    return ExactModel(restoring=(W * W,), damping=(2 * Z * W,), mu=0.0, r=1.0, f=F,
                      barrier=False, spectrum=Spectrum.of("white", D=D),
                      noise="additive", D_k=D_k, D_c=D_c)


def coefficients(D_k, D_c):
    a = 2 * Z * W - D_k * W**2 - 8 * D_c * Z**2 * W**2
    b = D_k * W**2 + 12 * D_c * Z**2 * W**2
    return a, b, 2 * D * F**2


@pytest.mark.parametrize(("D_k", "D_c"), [(0.02, 0.0), (0.0, 0.3), (0.01, 0.2)])
def test_energy_drift_and_diffusion_of_the_linear_oscillator(D_k, D_c):
    m = linear(D_k, D_c)
    A = np.array([0.3, 1.0, 2.0])
    E = 0.5 * W**2 * A**2
    a, b, s = coefficients(D_k, D_c)
    np.testing.assert_allclose(m.energy_terms(A)["sigma2"], s * E + b * E**2, rtol=1e-13)
    # the Ito drift of E from the amplitude form: m_E = g m_A + g' sigma_A^2 / 2 (E = U(A));
    # its noise-induced part comes from the 4-point stencil of T sigma_E^2 (truncation ~1e-12)
    g, gp = W**2 * A, W**2
    m_E = g * m.drift(A) + 0.5 * gp * m.diffusion(A)
    np.testing.assert_allclose(m_E, -a * E + D * F**2, rtol=1e-9)


@pytest.mark.parametrize(("D_k", "D_c"), [
    (0.01, 0.2), pytest.param(0.02, 0.0, marks=pytest.mark.slow),
    pytest.param(0.0, 0.3, marks=pytest.mark.slow)])
def test_stationary_law_of_the_linear_oscillator_is_the_closed_form(D_k, D_c):
    m = linear(D_k, D_c)
    amp = amplitude_density(m, points=201, scan=128, tail_mass=False)
    a, b, s = coefficients(D_k, D_c)
    E = 0.5 * W**2 * amp.A**2
    ref = (s + b * E) ** (-2 * a / b - 2) * W**2 * amp.A  # p_A = p(E) g(A)
    ref /= np.trapezoid(ref, amp.A)
    np.testing.assert_allclose(amp.p[1:], ref[1:], rtol=1e-9)  # measured 5e-14


def test_zero_intensity_is_bit_identical_to_none():
    from vifpk.core.scene import load_scene

    none = ExactModel.from_scene(load_scene("paper-base"))
    zero = dataclasses.replace(none, D_k=0.0, D_c=0.0)
    off = dataclasses.replace(none, D_k=0.0, D_c=1e-3)  # and the switch does switch
    A = np.linspace(0.05, 2.0, 9)
    for key, value in none.energy_terms(A).items():
        assert np.array_equal(zero.energy_terms(A)[key], value), key
    assert np.array_equal(none.drift(A), zero.drift(A))
    assert not np.array_equal(none.drift(A), off.drift(A))


@pytest.mark.slow
def test_fpk_on_the_parametric_drift_and_diffusion_meets_the_closed_form():
    from vifpk import fpk

    m = linear(0.01, 0.2)
    res = fpk.stationary(m.drift, m.diffusion, cells=400, method="direct")
    x, p = res.data["A_cells"]["x"], res.data["A_cells"]["p"]
    a, b, s = coefficients(0.01, 0.2)
    E = 0.5 * W**2 * x**2
    ref = (s + b * E) ** (-2 * a / b - 2) * W**2 * x
    h = res.info["grid"]["h"]
    ref /= np.sum(ref) * h
    # the FPK's usual bound at its default 400 cells (tests/test_fpk.py)
    assert np.sum(np.abs(p - ref)) * h <= 1e-4  # measured 8.9e-7
