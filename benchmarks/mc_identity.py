"""Bit-identity of the Monte Carlo across a refactor (issue 37): run small stationary, first-
passage, transient and splitting runs on a few scenes and write every output array to an .npz.

    NUMBA_NUM_THREADS=1 python benchmarks/mc_identity.py OUT.npz
    python benchmarks/mc_identity.py --compare A.npz B.npz   # exit 1 on any difference
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


def run(path: str) -> None:
    from vifpk.montecarlo import PassageSettings
    from vifpk.montecarlo.passage import first_passage
    from vifpk.montecarlo.simulate import Settings, simulate
    from vifpk.montecarlo.splitting import SplittingSettings, passage_splitting
    from vifpk.montecarlo.transient import snapshots

    from vifpk.core.scene import load_scene

    out: dict = {}
    for name in SCENES:
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
    np.savez(path, **out)
    print(f"{len(out)} arrays -> {path}")


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
    run(sys.argv[1])
