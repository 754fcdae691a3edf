"""Where a Monte Carlo run stopped, so that it can be extended later (issue 29, item 3).

A run toward a target floor samples window after window from one set of paths
(simulate.py); a ``Checkpoint`` is everything the next window needs: every path's state
(x, v, xi) and generator state, the histograms, counters and per-path sums so far, the
certificate's window means, and the plan that made them (time step, burn-in, stride,
samples per window, histogram edges, the relaxation pilot's result). ``simulate(...,
resume=checkpoint)`` continues those paths with the same random streams from the next window
on, toward its own (smaller) target floor: no pilot, no burn-in, no window run twice. The
kernel's results do not depend on how a run is cut into calls (simulate.py), so a run
continued from a checkpoint is bit-identical to the same windows run without a stop.

``to_bytes``/``from_bytes``: a numpy ``.npz`` archive (no pickle) with the scalars as JSON,
for files and for executors that move results between processes or machines. A checkpoint
knows the run it belongs to (``key``: the physics, the step, the seed, the paths and the
observables); resuming a different run raises ValueError naming what differs.
"""

from __future__ import annotations

import hashlib
import io
import json
from dataclasses import asdict, dataclass, field, is_dataclass
from typing import Any

import numpy as np

#: the arrays of stepper.Arrays (hist is kept as its own names, below)
_ARRAYS = ("rng", "state", "moments", "events", "stuck", "energy")
_HISTS = ("A", "x", "v", "joint")
_EDGES = ("edges_A", "edges_x", "edges_v")


def run_key(phys: dict[str, Any], h: float, seed: int, blocks: int, per_block: int,
            obs: tuple[str, ...], certificate: bool) -> str:
    """What a run is: sha256 of its physics, step, seed, paths and observables (16 hex)."""
    def plain(v: Any) -> Any:
        if is_dataclass(v):  # the scene's noise, a wall: names, numbers, (name, value) pairs
            return {k: plain(x) for k, x in asdict(v).items()}
        if isinstance(v, str) or v is None:
            return v
        if isinstance(v, tuple | list):
            return [plain(x) for x in v]
        return [float(x) for x in np.ravel(v)] if isinstance(v, np.ndarray) else float(v)

    text = json.dumps({"phys": {k: plain(v) for k, v in sorted(phys.items())}, "h": float(h),
                       "seed": int(seed), "blocks": int(blocks), "per_block": int(per_block),
                       "obs": list(obs), "certificate": bool(certificate)}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


@dataclass(frozen=True, kw_only=True)
class Checkpoint:
    """A run's state after ``run_to`` sampled windows (module docstring)."""

    key: str
    arrays: dict[str, np.ndarray | None]  # rng, state, moments, events, stuck, energy
    hist: dict[str, np.ndarray | None]  # A, x, v, joint and the edges
    windows: np.ndarray | None  # the certificate's per-path window sums
    run_to: int  # windows sampled
    n_burn: int  # burn-in steps
    stride: int  # steps between samples
    spw: int  # samples per window
    h: float
    steps: float  # path-steps simulated so far (pilots not counted)
    relax: dict[str, Any] | None  # the relaxation pilot's result ("auto" burn-in)
    notes: dict[str, Any] = field(default_factory=dict)  # JSON: the step's rule and check

    def to_bytes(self) -> bytes:
        """The checkpoint as an .npz archive (no pickle)."""
        arrays: dict[str, np.ndarray] = {}
        for k, v in self.arrays.items():
            if v is not None:
                arrays[f"a_{k}"] = v
        for k, v in self.hist.items():
            if v is not None:
                arrays[f"h_{k}"] = v
        if self.windows is not None:
            arrays["windows"] = self.windows
        meta = {"key": self.key, "run_to": self.run_to, "n_burn": self.n_burn,
                "stride": self.stride, "spw": self.spw, "h": self.h, "steps": self.steps,
                "relax": self.relax, "notes": self.notes}
        arrays["meta"] = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
        buf = io.BytesIO()
        np.savez(buf, **arrays)
        return buf.getvalue()

    @classmethod
    def from_bytes(cls, data: bytes) -> Checkpoint:
        """The inverse of :meth:`to_bytes`."""
        with np.load(io.BytesIO(data), allow_pickle=False) as z:
            meta = json.loads(bytes(z["meta"]).decode())
            arrays = {k: (np.array(z[f"a_{k}"]) if f"a_{k}" in z else None) for k in _ARRAYS}
            hist = {k: (np.array(z[f"h_{k}"]) if f"h_{k}" in z else None)
                    for k in (*_HISTS, *_EDGES)}
            windows = np.array(z["windows"]) if "windows" in z else None
        return cls(key=meta["key"], arrays=arrays, hist=hist, windows=windows,
                   run_to=int(meta["run_to"]), n_burn=int(meta["n_burn"]),
                   stride=int(meta["stride"]), spw=int(meta["spw"]), h=float(meta["h"]),
                   steps=float(meta["steps"]), relax=meta["relax"],
                   notes=meta.get("notes", {}))
