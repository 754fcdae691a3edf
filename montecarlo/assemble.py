"""Stage 5 of a stationary run (simulate.py): the Result. The densities of p(A), p(x1), p(x2)
and the joint law as block means with their standard errors and L1 noise floors, and info:
the settings as run, the seed, the effects, timings, the equilibration certificate
(certificate.py) and the stop, events, moments, the power balance, the run-time step check
(stepcheck.py) and, when asked, the checkpoint to continue from."""

from __future__ import annotations

import math
import platform
import time
from collections.abc import Callable
from typing import Any

import numba
import numpy as np
from vifpk.montecarlo import kernels as K
from vifpk.montecarlo.burnin import Started
from vifpk.montecarlo.certificate import certificate
from vifpk.montecarlo.checkpoint import Checkpoint, run_key
from vifpk.montecarlo.failures import diverged
from vifpk.montecarlo.rng import block_seeds
from vifpk.montecarlo.runplan import Clock, RunPlan, effects
from vifpk.montecarlo.sampling import Sampled
from vifpk.montecarlo.stepcheck import run_step_check
from vifpk.montecarlo.stepper import MAX_COLUMNS, Arrays, Stepper, path_sums
from vifpk.montecarlo.summary import (
    density,
    energy_summary,
    events_summary,
    mean_se,
    moments_summary,
)

from vifpk.core.result import Resolved, Result, Status


def densities(arr: Arrays, edges: dict[str, np.ndarray], obs: tuple[str, ...], h: float,
              cause: str) -> tuple[dict[str, dict[str, Any]], dict[str, float], np.ndarray]:
    """(data, the L1 floors, the samples per block): each histogram asked for as a density
    with its block errors (x2 with the weight of its atom at 0, the time at rest on a wall).
    Raises SimulationDiverged when every sample of A or x1 fell outside its range."""
    ev = arr.events
    samples = ev[:, K.EV_SAMPLES]
    if not samples.min() > 0:
        raise ValueError("no sample was taken: time must be at least sample_every")
    data: dict[str, dict[str, Any]] = {}
    names = {"A": ("A", "edges_A"), "x1": ("x", "edges_x"), "x2": ("v", "edges_v")}
    floors = {}
    for name, (key, ekey) in names.items():
        if arr.hist[key] is None:
            continue
        e = edges[ekey]
        d = density(arr.hist[key], samples, np.diff(e))
        data[name] = {"x": 0.5 * (e[1:] + e[:-1]), "p": d["p"], "edges": e, "err": d["err"],
                      "p_blocks": d["blocks"]}
        floors[name] = d["L1_floor"]
    if "x2" in data or "joint" in obs:
        atom = mean_se(ev[:, K.EV_ATOM] / samples)
        if "x2" in data:  # flat numbers, so that every density field stays an array
            data["x2"].update(atom_at=0.0, atom_weight=atom["value"], atom_err=atom["err"])
    if arr.hist["joint"] is not None:
        ex, evv = edges["edges_x"], edges["edges_v"]
        area = np.outer(np.diff(ex), np.diff(evv))
        d = density(arr.hist["joint"], samples, area)
        data["joint"] = {"x1": 0.5 * (ex[1:] + ex[:-1]), "x2": 0.5 * (evv[1:] + evv[:-1]),
                         "p": d["p"], "err": d["err"], "edges_x1": ex, "edges_x2": evv}
        floors["joint"] = d["L1_floor"]
    for name, col in (("A", K.EV_OUT_A), ("x1", K.EV_OUT_X)):
        if name in data and ev[:, col].sum() >= samples.sum():
            raise diverged(h, f"every sample of {name} fell outside its histogram range",
                           cause)
    return data, floors, samples


def assemble(system: Any, noise: Any, plan: RunPlan, clock: Clock, run: Started,
             done: Sampled, step: Stepper, simulate: Callable[..., Result]) -> Result:
    """The run's Result (module docstring). ``simulate``: the driver, for the step check's
    coarse run."""
    st, ck, obs, target, phys = plan.settings, plan.resume, plan.obs, plan.target, plan.phys
    blocks, per_block, threads = plan.blocks, plan.per_block, plan.threads
    h, edges, arr, n_burn, stride, spw = (run.h, run.edges, run.arr, run.n_burn, run.stride,
                                          run.spw)
    relax, dt_rule, pilot_s, win_steps = run.relax, run.dt_rule, run.pilot_s, run.win_steps
    windows, run_to, floor, run_s = done.windows, done.run_to, done.floor, done.run_s
    compile_s, deadline = clock.compile_s, clock.deadline
    laps, check_timing = step.laps, None
    data, floors, samples = densities(arr, edges, obs, h, step.cause)
    ev = arr.events
    sampled = run_to * win_steps * h
    burnt = n_burn * h + (run.coarse["time"] if run.coarse else 0.0)  # both parts
    n_coarse = round(run.coarse["time"] / run.coarse["dt"]) if run.coarse else 0
    steps = float(blocks * per_block * (n_coarse + n_burn + run_to * win_steps))
    info: dict[str, Any] = {
        "solver": "montecarlo",
        "steps_this_run": steps - (ck.steps if ck is not None else 0.0),
        "settings": {"paths": blocks * per_block, "dt": h, "time": sampled,
                     "burn_in": burnt, "sample_every": stride * h, "blocks": blocks,
                     "bins": st.bins, "observables": list(obs),
                     "dt_mode": "auto" if st.dt == "auto" else "fixed",
                     "burn_in_mode": "auto" if st.burn_in == "auto" else "fixed"},
        "seed": {"root": st.seed, "scheme": "path p of block b: words 4p..4p+3 of "
                 "numpy.random.SeedSequence(root, spawn_key=(b,)).generate_state",
                 "first_path_state": [int(v) for v in block_seeds(st.seed, 1, 1)[0, 0]]},
        "effects": effects(system, noise),
        "threads": threads,
        "order": {"weak": K.WEAK_ORDER_NONSMOOTH, "weak_smooth": K.WEAK_ORDER_SMOOTH,
                  "note": "Strang splitting: 2 on the smooth sub-system (no barrier, no "
                          "friction), 1 across impacts and stick-slip; measured in tests"},
        "L1_floor": floors,
        "seconds": {"compile": compile_s, "pilot": pilot_s, "run": run_s,
                    "total": time.perf_counter() - plan.t_start},
        "steps": steps, "steps_per_second": steps / step.busy if step.busy > 0 else math.nan,
        "versions": {"numba": numba.__version__, "numpy": np.__version__,
                     "python": platform.python_version()},
    }
    if relax is not None:
        info["relaxation"] = relax
    if dt_rule is not None:
        info["dt_rule"] = dt_rule
    if run.coarse is not None:  # the burn-in's part at a coarser step (burnin.py)
        info["burn_in_coarse"] = run.coarse
    laps.lap("densities")
    info["convergence"] = _convergence(plan, run, done, samples)
    laps.lap("certificate")
    if "events" in obs:
        info["events"] = events_summary(ev, ev[:, K.EV_TIME] * h, samples, h)
    if "moments" in obs:
        info["moments"] = moments_summary(path_sums(arr.moments, MAX_COLUMNS), samples)
    if arr.energy is not None:
        info["energy"] = energy_summary(path_sums(arr.energy), ev[:, K.EV_TIME] * h, phys)
    if "x2" in data:
        info["atoms"] = {"x2": {"at": 0.0, "weight": data["x2"]["atom_weight"],
                                "err": data["x2"]["atom_err"]}}
    info["warnings"] = []
    if ck is not None and ck.notes.get("dt_check"):  # the step and its check: the first stage's
        chk = {**ck.notes["dt_check"], "note": "checked when the run began (at its floor), "
               "not again for its continuation"}
        info["dt_check"] = chk
        if chk.get("verdict") == "failed":
            info["warnings"].append(chk["message"])
    elif st.dt == "auto" and st.dt_check and "A" in data:
        laps.lap("result")
        t3 = time.perf_counter()
        chk = run_step_check(simulate, system, noise, st, data["A"], edges, h, burnt,
                             sampled, floor, target, deadline, (dt_rule or {}).get("omega"),
                             reach=run.reach, start=arr.state.copy(),
                             tau=relax["tau"] if relax is not None else None)
        info["seconds"]["dt_check"] = time.perf_counter() - t3
        info["seconds"]["total"] = time.perf_counter() - plan.t_start
        laps.lap("dt_check")
        check_timing = chk.pop("timing", None)
        info["dt_check"] = chk
        if chk["verdict"] == "failed":
            info["warnings"].append(chk["message"])
    ok = all(np.all(np.isfinite(d["p"])) for d in data.values())
    if not ok:
        raise diverged(h, "non-finite histogram", step.cause)
    if ck is not None:
        info["resumed"] = {"windows": ck.run_to, "steps": ck.steps,
                           "note": "continued from a checkpoint: the same paths and random "
                                   "streams from its next window on (no pilot, no burn-in)"}
    if ck is not None and ck.notes.get("dt_rule"):
        info["dt_rule"] = ck.notes["dt_rule"]
    if st.keep_state:  # the key of the step it ran at (dt "auto" settles after the pilot)
        notes = {k: info[k] for k in ("dt_rule", "dt_check", "burn_in_coarse") if k in info}
        info["checkpoint"] = Checkpoint(
            key=run_key(phys, h, st.seed, blocks, per_block, obs, st.certificate), notes=notes,
            arrays={k: getattr(arr, k) for k in ("rng", "state", "moments", "events", "stuck",
                                                 "energy")},
            hist=dict(arr.hist), windows=windows, run_to=run_to, n_burn=n_burn, stride=stride,
            spw=spw, h=h, steps=steps, relax=relax)
    info["status"] = _status(info["convergence"])
    laps.lap("result")
    info["timing"] = laps.record()
    if check_timing:  # the coarse run's stages: machine-dependent, so not in info["dt_check"]
        info["timing"]["dt_check_run"] = check_timing
    cfg = info["settings"]
    return Result(data=data, info=info, resolved=Resolved(
        dt=cfg["dt"], burn_in=cfg["burn_in"], time=cfg["time"], paths=cfg["paths"],
        blocks=cfg["blocks"], sample_every=cfg["sample_every"]))


def _status(conv: dict[str, Any]) -> dict[str, Any]:
    """The run's outcome (vifpk.core.result.Status) from its convergence record: a failed
    certificate first, then a budget that stopped it short of its floor, else simulated."""
    if conv.get("equilibrated") is False:
        return Status.NOT_EQUILIBRATED.record(conv.get("reason", ""))
    if conv.get("reached") is False:
        return Status.STOPPED.record(f"L1 floor {conv['floor']:.4g} against the target "
                                     f"{conv['target_floor']:.4g}")
    return Status.SIMULATED.record()


def _convergence(plan: RunPlan, run: Started, done: Sampled, samples: np.ndarray
                 ) -> dict[str, Any]:
    """The equilibration certificate of the windows (certificate.py; none without windows)
    and how the run stopped against its target floor and budget."""
    st, obs, target = plan.settings, plan.obs, plan.target
    arr, h, n_burn, spw, win_steps = run.arr, run.h, run.n_burn, run.spw, run.win_steps
    windows, run_to, floor, stopped = done.windows, done.run_to, done.floor, done.stopped
    conv: dict[str, Any] = {}
    if windows is not None and run_to >= 1 and arr.moments is not None:
        m = path_sums(arr.moments, MAX_COLUMNS)
        var_A = float(np.sum(m[:, K.MO_A2]) / samples.sum()
                      - (np.sum(m[:, K.MO_A]) / samples.sum()) ** 2)
        conv = certificate(windows, spw, var_A, win_steps * h)
    elif windows is not None and run_to >= 1:
        conv = certificate(windows, spw, float(np.var(windows / spw)), win_steps * h)
    else:
        conv = {"equilibrated": None, "reason": "no certificate was asked for"}
    conv.update({"burn_in": n_burn * h + (run.coarse["time"] if run.coarse else 0.0),
                 "burn_in_mode": "auto" if st.burn_in == "auto" else "fixed",
                 "target_floor": target if target > 0 else None,
                 "floor": floor if "A" in obs else None,
                 "reached": (bool(floor <= target) if target > 0 else None),
                 "stopped": stopped, "budget": st.budget if st.budget else None})
    if run.relax is not None:
        conv["relaxation_time"] = run.relax["tau"]
    if target > 0 and not conv["reached"]:
        why = f"the budget of {st.budget:g} s ran out at L1 floor {floor:.4f}"
        conv["reason"] = "; ".join(r for r in (conv.get("reason"), why) if r)
    return conv
