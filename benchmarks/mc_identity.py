"""Bit-identity of the Monte Carlo across a refactor (issue 37): run small stationary, first-
passage, transient and splitting runs on a few scenes and write every output array to an .npz.

    NUMBA_NUM_THREADS=1 python benchmarks/mc_identity.py OUT.npz
    python benchmarks/mc_identity.py --compare A.npz B.npz   # exit 1 on any difference
    NUMBA_NUM_THREADS=1 python benchmarks/mc_identity.py OUT.npz --scenes paper-base,hard/white
"""

from __future__ import annotations

import sys

import numpy as np

SCENES = ("paper-base", "hard/white", "hard/mu-large", "systems/quintic", "systems/rayleigh",
          "hard/r-elastic", "systems/offset-parametric", "systems/bilateral-duffing",
          "paper-base+johnson", "systems/bilateral-duffing+johnson")
#: scenes made of a shipped one with overrides (the impact laws other than Newton's, issue 43)
OVERRIDES = {"+johnson": {"system.lower_wall.law": "johnson",
                          "system.lower_wall.v_yield": 0.5}}


def _flat(prefix: str, obj, out: dict) -> None:
    if isinstance(obj, dict):
        for k, v in obj.items():
            _flat(f"{prefix}.{k}", v, out)
    elif isinstance(obj, np.ndarray) and obj.dtype.kind in "fiub":
        out[prefix] = obj
    elif isinstance(obj, (float, int)) and not isinstance(obj, bool):
        out[prefix] = np.array(obj)


def run(path: str, scenes: tuple[str, ...] = SCENES) -> None:
    from vifpk.montecarlo import PassageSettings
    from vifpk.montecarlo.passage import first_passage
    from vifpk.montecarlo.simulate import Settings, simulate
    from vifpk.montecarlo.splitting import SplittingSettings, passage_splitting
    from vifpk.montecarlo.transient import snapshots

    from vifpk.core.scene import load_scene

    out: dict = {}
    for name in scenes:
        base, plus, extra = name.partition("+")
        sc = load_scene(f"scenes/{base}.toml")
        if plus:
            sc = sc.with_values(OVERRIDES[plus + extra])
        st = Settings(paths=64, blocks=8, dt=0.01, time=200.0, burn_in=50.0, seed=7, bins=40,
                      threads=1, floor=0.0, budget=0.0, sample_every=0.5,
                      progress=False, observables=("A", "x1", "x2", "moments", "energy"))
        r = simulate(sc.system, sc.noise, st)
        _flat(f"{name}.sim", r.data, out)
        ps = PassageSettings(paths=32, blocks=4, dt=0.01, horizon=100.0, seed=3, progress=False)
        r = first_passage(sc.system, sc.noise, ps, threshold=1.0, start=0.3)
        _flat(f"{name}.fpt", r.data, out)
        r = snapshots(sc.system, sc.noise, ps, start=0.5, times=[1.0, 5.0],
                      edges={"edges_A": np.linspace(0, 3, 31), "edges_x": np.linspace(-3, 3, 31),
                             "edges_v": np.linspace(-3, 3, 31)})
        _flat(f"{name}.snap", r.data, out)
        if name in ("paper-base", "hard/white"):
            ss = SplittingSettings(groups=2, particles=10, levels=10, dt=0.01, seed=5,
                                   cycles=5, paths=2, threads=1)
            r = passage_splitting(sc.system, sc.noise, ss, threshold=0.9, start=0.3, low=0.35,
                                  entry=0.5)
            _flat(f"{name}.split", r.data, out)
            # more paths than lanes, several groups; the stationary start (burn-in, restarts)
            ss = SplittingSettings(groups=3, particles=40, levels=20, dt=0.01, seed=6,
                                   cycles=4, paths=45, threads=1)
            r = passage_splitting(sc.system, sc.noise, ss, threshold=0.8, start="stationary",
                                  low=0.35, entry=0.5, burn_in=20.0)
            _flat(f"{name}.split_stationary", r.data, out)
    _averaged_sde(out)
    np.savez(path, **out)
    print(f"{len(out)} arrays -> {path}")


def _averaged_sde(out: dict) -> None:
    """The averaged SDE's time-domain runs and its splitting (per-path streams: bit-identical
    across a change of layout). Its stationary run (simulate_sde) is not here: issue 44 gave
    it per-path streams, so its numbers changed (tests/test_averaged_sde_lanes.py)."""
    from vifpk.montecarlo.sde_time import sde_first_passage, sde_snapshots
    from vifpk.montecarlo.splitting import (
        SplittingSettings,
        sde_escape_probability,
        sde_passage_splitting,
    )

    def drift(A):
        return -0.05 * A + 0.01 / A

    def diffusion(A):
        return 0.02 + 0.0 * A

    r = sde_first_passage(drift, diffusion, threshold=1.2, start=0.4, paths=70, blocks=3,
                          dt=0.05, horizon=400.0, seed=11, progress=False)
    _flat("sde.fpt", r.data, out)
    r = sde_snapshots(drift, diffusion, start=0.4, times=[1.0, 20.0], edges_A=np.linspace(0, 2, 21),
                      paths=70, blocks=3, dt=0.05, seed=12, progress=False)
    _flat("sde.snap", r.data, out)
    ss = SplittingSettings(groups=2, particles=20, levels=10, dt=0.05, seed=13, cycles=3,
                           paths=8, threads=1)
    r = sde_escape_probability(drift, diffusion, low=0.3, threshold=1.2, start=0.5, settings=ss)
    _flat("sde.escape", r.data, out)
    r = sde_passage_splitting(drift, diffusion, threshold=1.2, start=0.4, low=0.3, entry=0.6,
                              settings=ss)
    _flat("sde.split", r.data, out)


def compare(a: str, b: str) -> int:
    A, B = np.load(a), np.load(b)
    bad = [k for k in sorted(set(A) | set(B)) if k not in A or k not in B
           or A[k].shape != B[k].shape or not np.array_equal(A[k], B[k], equal_nan=True)]
    print(f"{len(A)} vs {len(B)} arrays; {len(bad)} differ" + (": " + ", ".join(bad[:20])
                                                             if bad else ""))
    return 1 if bad else 0


if __name__ == "__main__":
    if sys.argv[1] == "--compare":
        sys.exit(compare(sys.argv[2], sys.argv[3]))
    # --scenes a,b: only those scenes (and the averaged SDE's runs)
    run(sys.argv[1], tuple(sys.argv[3].split(",")) if sys.argv[2:3] == ["--scenes"] else SCENES)
