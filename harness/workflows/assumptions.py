"""Where the averaging assumptions fail: the warnings a check writes beside its numbers.

The kinds (``ASSUMPTION_KINDS``; ``ADVISORY`` ones keep the verdicts estimates) and their
thresholds, evaluated at the simulation's measured mean amplitude (docs/report.md,
"Warnings"). Split from check.py (issue 27).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from vifpk.harness.door.solvers import (
    SolverFailure,
    closed_form,
    energy_rates,
)

from vifpk.core.guard import PluginError
from vifpk.core.result import WarningRecord
from vifpk.physics import impact, spring
from vifpk.physics import noise as noise_kinds

#: The kinds of warning check writes (WarningRecord.kind): code acts on the kind (the
#: sweep's flags, advisory or not), people read the text.
#: Of them, the averaging assumptions that fail (assumption_warnings; the sweep's map flags);
#: "outside_range" and "dt_bias" (a failed run-time check of the automatic step,
#: montecarlo/tuning.py step_check) are diagnostics of the run, not of the model.
ASSUMPTION_KINDS = ("strong_damping", "narrow_band", "sticking", "strong_noise",
                    "correlated_noise", "strong_dissipation")


WARNING_KINDS = (*ASSUMPTION_KINDS, "outside_range", "dt_bias")


#: advisory kinds: the averaging assumptions hold, but the measured O(eps) remainder of the
#: averaged models is beyond the target there (docs/report.md, "Warnings"); the verdicts stay
#: estimates and check still recommends a model
ADVISORY = ("correlated_noise",)


def mean_amplitude(scene: Any, closed: dict[str, Any], mc_info: dict[str, Any]) -> float:
    """The mean amplitude the warnings are evaluated at: the simulation's measured one when
    there is a simulation (the truth, and the same whatever models are checked), else the
    exact averaged model's (computed here when it is not among ``closed``), else 1."""
    mean = mc_info.get("moments", {}).get("A", {}).get("mean", {}).get("value")
    if mean is not None and math.isfinite(mean) and mean > 0:
        return float(mean)
    if "exact" in closed:
        return float(closed["exact"].info["summary"]["mean"])
    try:
        return float(closed_form(scene, model="exact", tail_mass=False).info["summary"]["mean"])
    except (SolverFailure, PluginError):  # no exact density here: the warnings' scale is then 1
        return 1.0


def assumption_warnings(scene: Any, closed: dict[str, Any], mc_info: dict[str, Any],
                        val: dict[str, Any] | None = None) -> list[WarningRecord]:
    """Records (kind, sentence) naming each averaging assumption that clearly fails here.

    Stochastic averaging needs (i) weak damping and weak noise relative to the restoring
    force (quasi-conservative: the energy changes little over one period), (ii) a noise
    correlation time short against the relaxation of the amplitude (wide-band noise), and
    (iii) motion that oscillates rather than sticks, at the mean amplitude
    (:func:`mean_amplitude`). ``val``: the scene's validity numbers
    over the bulk of p(E) (run.validity); the narrow-band test uses alpha1 / Omega(E) there
    (at the mean amplitude without them). Thresholds: docs/report.md, "Warnings".
    """
    n = scene.noise
    out = []
    A = mean_amplitude(scene, closed, mc_info)
    rates = energy_rates(scene, A)
    T, E = rates["T"], rates["E"]
    w = 2 * math.pi / T
    parts = _loss_parts(rates)
    rate = sum(parts.values()) / E
    if rate * T > 0.5:
        main = max(parts, key=lambda k: parts[k])
        out.append(WarningRecord(
            "strong_damping",
            f"strong damping: at the mean amplitude {A:.3g} the energy changes by "
            f"{rate * T:.2f} of itself per period (mostly {main}), so the energy is not "
            "nearly conserved over one cycle, which averaging assumes"))
    band = (val or {}).get("band")
    # a kind with a correlation time (its module declares avg_correlation_rate: OU, ...), not
    # a kind named "ou": a third coloured kind is warned about too
    coloured = n.kind in noise_kinds.kinds_with("averaging", "correlation_rate")
    if coloured and band is not None and min(band) < BAND_MIN:
        lo, hi = min(band), max(band)
        out.append(WarningRecord(
            "narrow_band",
            f"narrow-band noise: bandwidth alpha1 = {n.alpha1:g} is {lo:.2g}-{hi:.2g} x "
            "the oscillation frequency over the bulk of p(E) (10%-90% energies), below "
            f"{BAND_MIN:g}; the noise is not wide-band against the oscillation, which the "
            "Stratonovich-Khasminskii limit requires"))
    elif coloured and band is None and (corr_rate := float(noise_kinds.piece(
            n.kind, "averaging", "correlation_rate")(D=n.D, alpha1=n.alpha1))) < BAND_MIN * w:
        out.append(WarningRecord(
            "narrow_band",
            f"narrow-band noise: bandwidth alpha1 = {corr_rate:g} is below {BAND_MIN:g} x "
            f"the oscillation frequency ({w:.3g}) at the mean amplitude; the noise is not "
            "wide-band against the oscillation, which the Stratonovich-Khasminskii limit "
            "requires"))
    corr = (val or {}).get("correlation")
    if corr is not None and corr[1] > CORRELATION_MAX:
        out.append(WarningRecord(
            "correlated_noise",
            f"correlated noise: over one correlation time 1/alpha1 the noise changes the "
            f"energy by {100 * math.sqrt(corr[1]):.0f}% (rms) at the median energy "
            f"(sigma_E^2 / (alpha1 E^2) = {corr[1]:.3f} > {CORRELATION_MAX:g}); there the "
            "better of exact and corrected was measured at L1(A) = 0.017-0.066, against at "
            "most 0.028 below the threshold (docs/report.md)"))
    stuck = mc_info.get("events", {}).get("stuck_fraction", {}).get("value", 0.0)
    if stuck > 0.1:
        out.append(WarningRecord(
            "sticking",
            f"sticking-dominated motion: the mass is stuck {100 * stuck:.0f}% of the time "
            "in the simulation; averaging over free oscillations does not describe it"))
    if A > 0:
        ratio = rates["sigma2_E"] * T / E**2
        if ratio > NOISE_MAX:
            w = _exchange_warning(scene, A, rates, ratio, val)
            # strong damping already names the loss as what is large: one warning, not two
            if w.kind != "strong_dissipation" or all(o.kind != "strong_damping" for o in out):
                out.append(w)
    return out


LOSSES = ("linear damping", "cubic damping", "velocity damping", "impacts", "friction")


def _loss_parts(rates: dict[str, float]) -> dict[str, float]:
    """The energy rate of each dissipative effect, in magnitude: on a limit cycle the linear
    feed and the cubic damping cancel on average, yet each changes the energy within the
    cycle."""
    return {k: rates.get(k, 0.0) for k in LOSSES}


def _exchange_warning(scene: Any, A: float, rates: dict[str, float], ratio: float,
                      val: dict[str, Any] | None) -> WarningRecord:
    """The warning for a large relative energy change per period at the mean amplitude,
    sigma_E^2 T / E^2 > NOISE_MAX, named after its cause (issue 45, item 4).

    At stationarity the energy the noise feeds equals, on average over p(E), the energy the
    losses take: with external noise of intensity D f^2 the feed is D f^2 per unit time, so
    <loss rate> = D f^2, and sigma_E^2 = 2 D f^2 <v^2>_orbit ~ 2 D f^2 E gives
    sigma_E^2 T / E^2 ~ 2 <loss rate> T / E at the mean amplitude (exact for the linear spring
    with white noise). The ratio the losses account for is therefore ``balance`` = 2 <loss> T/E,
    <loss> the mean of the losses' rates (:func:`_loss_parts`) over the bulk of p(E) (the 10%,
    50% and 90% amplitudes of ``val``; the mean amplitude alone without them). When it is at
    least half the ratio, the fluctuation is what impacts and damping cost (the knob is the
    loss: restitution, damping) and the warning is ``strong_dissipation``, naming the largest
    loss over the bulk; otherwise the noise itself is strong for the energy it acts on (e.g. a
    parametric noise, whose sigma_E^2 grows like E^2) and it stays ``strong_noise``. The
    firing condition is the strong-noise one, unchanged (docs/report.md)."""
    T, E = rates["T"], rates["E"]
    amps = [a for a in (val or {}).get("amplitudes") or () if a > 0] or [A]
    bulk = [energy_rates(scene, a) for a in amps]
    mean = {k: sum(_loss_parts(r)[k] for r in bulk) / len(bulk) for k in LOSSES}
    balance = 2.0 * sum(mean.values()) * T / E
    rms = 100 * math.sqrt(ratio)
    if balance < 0.5 * ratio:
        return WarningRecord(
            "strong_noise",
            f"strong noise: over one period the noise changes the energy by {rms:.0f}% (rms) "
            "at the mean amplitude; averaging assumes it changes little (the losses account "
            f"for {100 * balance / ratio:.0f}% of that variance at stationarity: the noise "
            "itself is strong here)")
    main = max(mean, key=lambda k: mean[k])
    top = max(sum(_loss_parts(r).values()) * r["T"] / r["E"] for r in bulk)
    took = f"{100 * top:.0f}% of the energy" if top < 1 else f"{top:.3g} x the energy"
    knob = KNOBS[main]
    return WarningRecord(
        "strong_dissipation",
        f"strong dissipation: the losses take up to {took} per period over the bulk of "
        f"p(E), mostly {main}, and at stationarity the noise feeds on average what they "
        f"take, so at the mean amplitude the energy changes by {rms:.0f}% (rms) per period; "
        f"averaging assumes it changes little. Lowering the loss ({knob}) lowers it, as "
        "lowering the noise does")


#: what lowers each loss, for the strong-dissipation warning's advice
KNOBS = {"linear damping": "less damping", "cubic damping": "less damping at large amplitude",
         "velocity damping": "less damping", "impacts": "restitution r closer to 1",
         "friction": "less friction"}


BAND_MIN = 0.5  # narrow-band warning: alpha1 / Omega(E) below this anywhere in the bulk


WALL_MAX = 0.2  # corrected trusted only while delta / E <= this at the 10% energy


NOISE_MAX = 0.5  # strong noise or dissipation: sigma_E^2 T / E^2 at the mean amplitude above this


CORRELATION_MAX = 0.045  # advisory: sigma_E^2 / (alpha1 E^2) at the median energy


#: corrected's compounded impact loss -ln(e^2) K against the loss (1 - e^2) K an impact takes:
#: beyond this ratio at a first-passage threshold, corrected's MFPT is outside its derivation
COMPOUNDED_MAX = 1.2


def compounded_tail(scene: Any, threshold: float) -> str | None:
    """A warning for ``corrected``'s MFPT at an amplitude threshold (issue 45, item 5), or None.

    ``corrected`` charges each impact the compounded loss lambda K, lambda = -ln e(v)^2, K the
    kinetic energy at the wall: first order in lambda (docs/averaging.md sections 10 and 11),
    where it and the loss the impact takes, (1 - e^2) K, agree; their ratio lambda / (1 -
    e^-lambda) = 1 + lambda / 2 + ... grows with lambda. With a speed-dependent law lambda
    grows without bound with the impact speed (Johnson: -2 ln r + (1/2) ln(v / v_yield) above
    v_yield), and an MFPT far in the tail is exponential in the integrated drift, so the
    excess compounds: on three held-out wall scenes corrected's MFPT far in the tail was off
    by +80%, +346% and x177 (the last on a Johnson wall, where exact was within 35%). The
    warning fires when the ratio at the threshold energy U(Ac), at the wall where it is
    largest, exceeds COMPOUNDED_MAX (a convention: docs/averaging.md measured the compounded
    treatment better than exact's where an impact takes 10-19% of K, a ratio below 1.11)."""
    k = tuple(scene.system.restoring_law)
    E = float(spring.potential(np.asarray(float(threshold)), k))
    worst = None
    for w in scene.system.walls:
        K = E - float(spring.potential(np.asarray(float(w.at)), k))
        if K <= 0:
            continue
        v = math.sqrt(2.0 * K)
        e = float(impact.law(w.law).restitution(v, w.r, w.v_yield or math.inf))
        if not 0.0 < e < 1.0:
            continue
        lam = -math.log(e * e)
        ratio = lam / (1.0 - e * e)
        if worst is None or ratio > worst[0]:
            worst = (ratio, w, v, e, lam)
    if worst is None or worst[0] <= COMPOUNDED_MAX:
        return None
    ratio, w, v, e, lam = worst
    return (f"corrected's MFPT is outside its derivation at this threshold: at the impact "
            f"speed {v:.3g} of Ac = {threshold:g} on the {w.side} wall ({w.law} law, e = "
            f"{e:.3f}) corrected charges -ln(e^2) K = {ratio:.2f} x the energy the impact "
            f"takes, (1 - e^2) K, beyond {COMPOUNDED_MAX:g} (its loss is first order in "
            f"lambda = -ln e^2 = {lam:.2f}), and the further in the tail the threshold, the "
            "more its MFPT compounds that excess (docs/passage.md); exact charges the impact's "
            "own loss")
