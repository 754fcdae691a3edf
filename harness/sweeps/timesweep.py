"""The time-domain workflows in sweeps (harness/sweeps/spec.py): ``workflow = "passage"`` and
``workflow = "transient"``, their tables, their point functions and their sweep figures::

    workflow = "passage"
    [passage]
    threshold = 2.0              # Ac; or vary it: [vary] "passage.threshold" = [...]
    start = "stationary"         # or an amplitude A0 < Ac (default "stationary")
    horizon = 5000.0             # optional; default 8 x the largest model MFPT
    sde = false                  # optional: also the averaged SDEs' Monte Carlo (default off)
    method = "direct"            # or "splitting": the MFPT only, at thresholds direct
                                 # simulation cannot reach (no horizon; particles, groups)
    rel_se = 0.045               # optional: the MFPT's target relative standard error
    max_paths = 16384            # optional: its paths cap (docs/passage.md, "Precision")

    workflow = "transient"
    [transient]
    start = 1.0                  # A0; or vary "transient.start"
    times = [5.0, 10.0, 20.0, 40.0]

A sweep over ``passage.threshold`` gives the MFPT-versus-threshold curve of every model against
the original system (log scale). A point whose first-passage Monte Carlo would cost more than
POINT_SECONDS at MC_STEPS_PER_CORE fails with that estimate instead of running (rare events).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

#: workflow parameters that a sweep may vary or fix in its table, by workflow
TIME_PARAMS = {"passage.threshold": "passage", "passage.start": "passage",
               "transient.start": "transient"}
KEYS = {"passage": ("threshold", "start", "horizon", "sde", "method", "particles", "groups",
                    "rel_se", "max_paths"),
        "transient": ("start", "times", "sde", "rel_se", "max_paths")}
POINT_SECONDS = 3600.0  # a point's Monte Carlo is refused above an hour at the fastest rate


class _Field:
    type = "float"


def field_of(path: str) -> Any:
    """A numeric stand-in field for a time workflow parameter, else None."""
    return _Field() if path in TIME_PARAMS else None


def options(src: str, raw: Mapping[str, Any], workflow: str, vary: Mapping[str, Any]
            ) -> dict[str, Any]:
    """The [passage] or [transient] table, validated (SweepError naming the key); {} for the
    other workflows (which may not have these tables nor vary their parameters)."""
    from vifpk.harness.sweeps.errors import SweepError

    for wf in KEYS:
        if wf != workflow and wf in raw:
            raise SweepError(f"{src}: [{wf}]: only for workflow = '{wf}'")
    for key in vary:
        if key in TIME_PARAMS and TIME_PARAMS[key] != workflow:
            raise SweepError(f"{src}: [vary] {key!r}: only for workflow = "
                             f"'{TIME_PARAMS[key]}'")
    if workflow not in KEYS:
        return {}
    table = raw.get(workflow, {})
    if not isinstance(table, Mapping):
        raise SweepError(f"{src}: [{workflow}] must be a table")
    for k in table:
        if k not in KEYS[workflow]:
            raise SweepError(f"{src}: [{workflow}] {k}: unknown key; allowed: "
                             + ", ".join(KEYS[workflow]))
        if f"{workflow}.{k}" in vary:
            raise SweepError(f"{src}: [{workflow}] {k}: also in [vary]; keep one")
    opts = dict(table)
    if workflow == "passage":
        if "threshold" not in opts and "passage.threshold" not in vary:
            raise SweepError(f"{src}: [passage] threshold: missing (a number, or vary "
                             "\"passage.threshold\")")
        opts.setdefault("start", "stationary")
        st = opts["start"]
        if st != "stationary" and not _finite(st):
            raise SweepError(f"{src}: [passage] start = {st!r}: an amplitude or 'stationary'")
        if "horizon" in opts and not (_finite(opts["horizon"]) and opts["horizon"] > 0):
            raise SweepError(f"{src}: [passage] horizon = {opts['horizon']!r}: a time > 0")
        method = opts.get("method", "direct")  # not set by default: fingerprints kept
        if method not in ("direct", "splitting"):
            raise SweepError(f"{src}: [passage] method = {method!r}: allowed: 'direct', "
                             "'splitting'")
    else:
        if "start" not in opts and "transient.start" not in vary:
            raise SweepError(f"{src}: [transient] start: missing (an amplitude)")
        t = opts.get("times")
        if (not isinstance(t, list) or len(t) < 3 or not all(_finite(x) and x > 0 for x in t)
                or any(b <= a for a, b in zip(t, t[1:], strict=False))):
            raise SweepError(f"{src}: [transient] times = {t!r}: a list of at least 3 "
                             "times > 0 in increasing order (the relaxation fit has two "
                             "parameters)")
        opts["times"] = [float(x) for x in t]
    sde = opts.setdefault("sde", False)
    if not isinstance(sde, bool):
        raise SweepError(f"{src}: [{workflow}] sde = {sde!r}: true or false")
    return opts


def _finite(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def point_options(opts: Mapping[str, Any], params: tuple[tuple[str, float], ...]
                  ) -> dict[str, Any]:
    """The workflow's options at a point: the table with the point's varied ones."""
    out = dict(opts)
    for k, v in params:
        if k in TIME_PARAMS:
            out[k.split(".", 1)[1]] = float(v)
    return out


def check_point(workflow: str, opts: Mapping[str, Any], scene: Any) -> None:
    """The point's options as the command checks them: the same request, the same one line
    (harness/request/timedomain.py; InputError). A scene that is a numerical dead end (no
    noise) is left to the point's run, which says so."""
    from vifpk.harness.door.solvers import SolverFailure

    try:
        request(workflow, opts, scene, None)
    except SolverFailure:
        pass


def request(workflow: str, opts: Mapping[str, Any], scene: Any, models: Any) -> Any:
    """The point's PassageRequest or TransientRequest (harness/request/timedomain.py)."""
    from vifpk.harness.request.timedomain import passage_request, transient_request

    if workflow == "passage":
        return passage_request(scene, threshold=opts["threshold"], start=opts["start"],
                               models=models, horizon=opts.get("horizon"), sde=opts["sde"],
                               method=opts.get("method", "direct"),
                               particles=opts.get("particles"), groups=opts.get("groups"),
                               rel_se=opts.get("rel_se"), max_paths=opts.get("max_paths"))
    return transient_request(scene, start=opts["start"], times=opts["times"], models=models,
                             sde=opts["sde"], rel_se=opts.get("rel_se"),
                             max_paths=opts.get("max_paths"))


def _price(p: dict[str, Any], runs: int) -> None:
    from vifpk.harness.door.solvers import SolverFailure
    from vifpk.harness.request.cost import MC_STEPS_PER_CORE
    from vifpk.harness.workflows.passage import run_seconds

    s = run_seconds(p, runs, MC_STEPS_PER_CORE, 1)
    if s > POINT_SECONDS:
        raise SolverFailure(f"out of reach: the averaged models put the MFPT at up to "
                            f"{p['largest_model_mfpt']:.3g}, so the Monte Carlo would take at "
                            f"least {s / 3600:.3g} core-hours (rare events)")


def passage_point(job: Any) -> dict[str, Any]:
    from vifpk.harness.request.timedomain import with_quadratures
    from vifpk.harness.workflows.passage import run

    o = point_options(job.bifurcation, job.params)
    req = with_quadratures(request("passage", o, job.scene, job.models))
    if req.method == "splitting":
        return _splitting_point(req)
    res = run(req, quiet=True,
              price=lambda p: _price(p, 1 + (len(req.models) if o["sde"] else 0)))
    mc = res.metrics["mfpt"]["original_system"]
    out: dict[str, Any] = {"models": {}}
    for m in res.models:
        e = res.metrics["models"][m]
        err = e.get("mfpt_error_restricted", e["mfpt_error"])
        out["models"][m] = {"mfpt": res.metrics["mfpt"][m]["value"],
                            "mfpt_error": err["value"], "mfpt_error_err": err["err"],
                            "R_sup": e["R_sup"]["value"], "R_sup_floor": e["R_sup"]["floor"],
                            "verdict_class": e["verdict_class"]}
    out.update(mfpt_original=mc["value"], mfpt_original_err=mc["stderr"],
               censored_fraction=res.metrics["plan"]["censored_fraction"],
               recommended_model=res.metrics["recommended_model"],
               warnings=res.warnings, verdicts=res.verdicts)
    return out


def _splitting_point(req: Any) -> dict[str, Any]:
    """A passage point by splitting (harness/workflows/rarepassage.py): the same record as a
    direct point's, with the R(t) distances not measured (NaN) and nothing censored."""
    from vifpk.harness.workflows import rarepassage

    res = rarepassage.run(req, reason="asked for: [passage] method = 'splitting'")
    met = res.metrics
    out: dict[str, Any] = {"models": {
        m: {"mfpt": e["mfpt"], "mfpt_error": e["mfpt_error"]["value"],
            "mfpt_error_err": e["mfpt_error"]["err"], "R_sup": math.nan,
            "R_sup_floor": math.nan, "verdict_class": e["verdict_class"]}
        for m, e in met["models"].items()}}
    o = met["mfpt"]["original_system"]
    out.update(mfpt_original=o["value"], mfpt_original_err=o["stderr"], censored_fraction=0.0,
               recommended_model=met["recommended_model"], warnings=res.warnings,
               verdicts=res.verdicts)
    return out


def transient_point(job: Any) -> dict[str, Any]:
    from vifpk.harness.workflows.transient import run

    o = point_options(job.bifurcation, job.params)
    res = run(request("transient", o, job.scene, job.models), quiet=True)
    meas = res.metrics["relaxation"]["original_system"]
    out: dict[str, Any] = {"models": {}}
    for m in res.models:
        e = res.metrics["models"][m]
        worst = max(r["fpk"]["L1"] for r in e["snapshots"])
        out["models"][m] = {"relaxation_time": e["relaxation"]["predicted"],
                            "relaxation_fitted": e["relaxation"]["fitted"],
                            "worst_L1_A": worst, "verdict_class": e["verdict_class"]}
    out.update(relaxation_original=meas["value"] if meas else math.nan,
               relaxation_original_err=meas["err"] if meas else math.nan,
               warnings=res.warnings, verdicts=res.verdicts)
    return out


#: point-level scalars of these workflows that sweep.dataset writes as variables
SCALARS = ("mfpt_original", "mfpt_original_err", "censored_fraction", "relaxation_original",
           "relaxation_original_err")
