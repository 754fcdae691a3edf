"""Where the averaging assumptions fail: the warnings a check writes beside its numbers.

The kinds (``ASSUMPTION_KINDS``; ``ADVISORY`` ones keep the verdicts estimates) and their
thresholds, evaluated at the simulation's measured mean amplitude (docs/report.md,
"Warnings"). Split from check.py (issue 27).
"""

from __future__ import annotations

import math
from typing import Any

from vifpk.harness.door.solvers import (
    SolverFailure,
    closed_form,
    energy_rates,
)

from vifpk.core.guard import PluginError
from vifpk.core.result import WarningRecord
from vifpk.physics import noise as noise_kinds

#: The kinds of warning check writes (WarningRecord.kind): code acts on the kind (the
#: sweep's flags, advisory or not), people read the text.
#: Of them, the averaging assumptions that fail (assumption_warnings; the sweep's map flags);
#: "outside_range" and "dt_bias" (a failed run-time check of the automatic step,
#: montecarlo/tuning.py step_check) are diagnostics of the run, not of the model.
ASSUMPTION_KINDS = ("strong_damping", "narrow_band", "sticking", "strong_noise",
                    "correlated_noise")


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
    # the energy rate of each effect in magnitude: on a limit cycle the linear feed and the
    # cubic damping cancel on average, yet each changes the energy within the cycle
    parts = {k: rates.get(k, 0.0) for k in ("linear damping", "cubic damping",
                                             "velocity damping", "impacts", "friction")}
    rate = sum(parts.values()) / E
    if rate * T > 0.5:
        main = max(parts, key=lambda k: parts[k])
        out.append(WarningRecord(
            "strong_damping",
            f"strong damping: at the mean amplitude {A:.3g} the energy changes by "
            f"{rate * T:.2f} of itself per period (mostly {main}), so the energy is not "
            "nearly conserved over one cycle, which averaging assumes"))
    band = (val or {}).get("band")
    # a kind with a correlation time (it declares AveragingNoise.correlation_rate: OU, ...),
    # not a kind named "ou": a third coloured kind is warned about too
    coloured = n.kind in noise_kinds.kinds_with("averaging", "correlation_rate")
    corr_rate = (float(noise_kinds.pieces(n.kind, "averaging").correlation_rate(**n.values))
                 if coloured else None)
    if coloured and band is not None and min(band) < BAND_MIN:
        lo, hi = min(band), max(band)
        out.append(WarningRecord(
            "narrow_band",
            f"narrow-band noise: bandwidth {corr_rate:g} (the {n.kind} noise's correlation "
            f"rate) is {lo:.2g}-{hi:.2g} x "
            "the oscillation frequency over the bulk of p(E) (10%-90% energies), below "
            f"{BAND_MIN:g}; the noise is not wide-band against the oscillation, which the "
            "Stratonovich-Khasminskii limit requires"))
    elif coloured and band is None and corr_rate is not None and corr_rate < BAND_MIN * w:
        out.append(WarningRecord(
            "narrow_band",
            f"narrow-band noise: bandwidth {corr_rate:g} (the {n.kind} noise's correlation "
            f"rate) is below {BAND_MIN:g} x "
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
        if ratio > 0.5:
            out.append(WarningRecord(
                "strong_noise",
                f"strong noise: over one period the noise changes the energy by "
                f"{100 * math.sqrt(ratio):.0f}% (rms) at the mean amplitude; averaging "
                "assumes it changes little"))
    return out


BAND_MIN = 0.5  # narrow-band warning: alpha1 / Omega(E) below this anywhere in the bulk


WALL_MAX = 0.2  # corrected trusted only while delta / E <= this at the 10% energy


CORRELATION_MAX = 0.045  # advisory: sigma_E^2 / (alpha1 E^2) at the median energy
