"""Test doubles of the time-domain doors (harness/door/timedomain.py: passage_* /
transient_*) with known answers: every first-passage time is exponential (mean T per model, T0 for
the original
system), so the relative MFPT error is T / T0 - 1 exactly; every snapshot law is a normal law
whose mean relaxes as a(t) = a_inf + (A0 - a_inf) exp(-t / tau), so the fitted relaxation time
is tau. The fast tier runs the workflows, the CLI and the reports on them in milliseconds."""

from __future__ import annotations

import math

import numpy as np

from vifpk.core.result import Result

T_MODEL = {"paper": 80.0, "exact": 100.0, "corrected": 118.0}
T_ORIGINAL = 120.0
TAU = {"paper": 8.0, "exact": 10.0, "corrected": 12.0}
TAU_ORIGINAL = 12.0
A_INF, WIDTH = 1.2, 0.3


def _t_of(model) -> float:
    return T_MODEL.get(model if isinstance(model, str) else "exact", 100.0)


def passage_averaged(scene, model, *, threshold, start, **kw):
    T = _t_of(model)
    t = np.linspace(0.0, 12 * T, 2001)
    R = np.exp(-t / T)
    return Result(data={"R": {"t": t, "R": R}, "fpt_density": {"t": t, "p": R / T}},
                  info={"solver": "fpk", "mfpt": T, "mfpt_error": 1e-9,
                        "mfpt_integral": T * (1 - math.exp(-12)), "decay_rate": 1 / T,
                        "threshold": threshold, "start": start})


def mfpt_averaged(scene, model, *, threshold, start):
    return {"value": _t_of(model), "error_estimate": 1e-9}


def _fpt(T, paths, horizon, seed):
    tau = np.random.default_rng(seed).exponential(T, paths)
    cens = tau > horizon
    return {"time": np.minimum(tau, horizon), "censored": cens}


def _seed(scene, seed):
    """The door's rule: the seed given, else the scene's montecarlo.seed."""
    return scene.montecarlo.seed if seed is None else seed


def passage_montecarlo(scene, *, threshold, start, horizon, paths, seed=None, **kw):
    f = _fpt(T_ORIGINAL, paths, horizon, _seed(scene, seed))
    return Result(data={"fpt": f}, info={"solver": "montecarlo", "method": "first_passage",
                                         "threshold": threshold, "horizon": horizon,
                                         "paths": paths, "censored": int(f["censored"].sum()),
                                         "dt": scene.montecarlo.dt,
                                         "seed": _seed(scene, seed)})


def passage_sde(scene, model, *, threshold, start, horizon, paths, seed, **kw):
    assert not isinstance(start, str), "the SDE gets amplitudes, never 'stationary'"
    f = _fpt(_t_of(model), paths, horizon, seed)
    return Result(data={"fpt": f}, info={"solver": "montecarlo", "method": "sde_first_passage",
                                         "censored": int(f["censored"].sum())})


def _mean(t, tau, a0):
    return A_INF + (a0 - A_INF) * np.exp(-np.asarray(t) / tau)


def transient_averaged(scene, model, *, start, times, **kw):
    tau = TAU.get(model if isinstance(model, str) else "exact", 10.0)
    x = np.linspace(0.0, 4.0, 401)
    P = np.array([np.exp(-0.5 * ((x - a) / WIDTH) ** 2) for a in _mean(times, tau, start)])
    P /= np.trapezoid(P, x, axis=1)[:, None]
    return Result(data={"snapshots": {"t": np.asarray(times), "x": x, "p": P}},
                  info={"solver": "fpk", "relaxation_time": tau})


def _hists(times, tau, a0, edges, paths, seed):
    rng = np.random.default_rng(seed)
    P, E = [], []
    w = np.diff(edges)
    for a in _mean(times, tau, a0):
        s = rng.normal(a, WIDTH, paths)
        c, _ = np.histogram(s, edges)
        P.append(c / (paths * w))
        E.append(np.sqrt(np.maximum(c, 1)) / (paths * w))
    return {"edges": edges, "x": 0.5 * (edges[1:] + edges[:-1]), "p": np.array(P),
            "err": np.array(E)}


def transient_montecarlo(scene, *, start, times, edges, paths, seed=None, **kw):
    h = _hists(times, TAU_ORIGINAL, start, edges["edges_A"], paths, _seed(scene, seed))
    return Result(data={"snapshots": {"t": np.asarray(times), "A": h}},
                  info={"solver": "montecarlo", "method": "snapshots", "paths": paths,
                        "seed": {"root": _seed(scene, seed)}})


def transient_sde(scene, model, *, start, times, edges_A, paths, seed, **kw):
    tau = TAU.get(model if isinstance(model, str) else "exact", 10.0)
    h = _hists(times, tau, start, edges_A, paths, seed)
    return Result(data={"snapshots": {"t": np.asarray(times), "A": h}},
                  info={"solver": "montecarlo", "method": "sde_snapshots"})


DOORS = ("mfpt_averaged", "passage_averaged", "passage_montecarlo", "passage_sde",
         "transient_averaged", "transient_montecarlo", "transient_sde")


def install(monkeypatch) -> None:
    """Every time-domain door (harness/door/timedomain.py) replaced by its double; the
    workflows call them as ``timedomain.<name>``, so the module attribute is what they see."""
    import vifpk.harness.door.timedomain

    this = globals()
    for name in DOORS:
        monkeypatch.setattr(vifpk.harness.door.timedomain, name, this[name])

