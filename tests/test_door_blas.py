"""The door's BLAS guard (harness/door/boundary.py, ``one_blas_thread``): every BLAS library a
door call can use runs on one thread inside the call, whatever the caller set, and comes back
to the caller's setting after it; but the guard itself imports no scipy (issue 44: ``import
scipy.linalg`` was 0.3-0.8 s CPU of a warm ``vifpk solve --solver montecarlo`` that uses no
scipy).

Why the limit matters: OpenBLAS cuts a product differently with its thread count, so results
moved by ~1e-15 between executors (tests/test_architecture.py::
test_door_results_do_not_depend_on_the_blas_thread_count checks numpy's BLAS on the exact
model's closed form). scipy's wheel carries its own OpenBLAS, loaded only when scipy's first
BLAS-linked module is (scipy.special, scipy.integrate, scipy.linalg, ...): these tests load it
first INSIDE a door call, in fresh interpreters (nothing else loaded it before), with the
caller's limit at 2 threads, and read every library's thread count from threadpoolctl. After
the call every library is as it would be without the door: numpy's at the caller's limit,
scipy's at its count when loaded outside any call (a fresh interpreter's; it depends on the
environment: OPENBLAS_NUM_THREADS, which dask's workers set in this very test process, and
the cores), so the interpreters run without the *_NUM_THREADS variables.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

from tests.conftest import ROOT

HEAD = """
import json, sys
from threadpoolctl import threadpool_info, threadpool_limits
from vifpk.harness.door.boundary import boundary

def blas():
    return {i["filepath"]: i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"}

out = {}
"""

#: scipy first imported inside a nested door call; the outer call goes on with it loaded
FIRST_INSIDE = HEAD + """
@boundary
def plain():
    return blas()

@boundary
def inner():
    import scipy.special  # loads scipy's OpenBLAS (no scipy.linalg of its own)
    out["inner, after scipy came in"] = blas()

@boundary
def outer():
    inner()
    out["outer, after the inner call"] = blas()

with threadpool_limits(limits=2, user_api="blas"):
    out["plain call"] = plain()
    out["scipy after a plain call"] = "scipy" in sys.modules
    out["caller before"] = blas()
    outer()
    out["caller after"] = blas()
    out["again, inside"] = plain()
print(json.dumps(out))
"""

#: scipy imported (no BLAS of its own yet) before the call; its BLAS loaded during the call
#: by a module that needs no new import of the ``scipy`` package
SCIPY_BEFORE = HEAD + """
import scipy
out["loaded before"] = blas()

@boundary
def call():
    import scipy.integrate
    out["inside"] = blas()

with threadpool_limits(limits=2, user_api="blas"):
    out["caller numpy's"] = blas()
    call()
    out["caller after"] = blas()
print(json.dumps(out))
"""


#: scipy's BLAS loaded outside any door call: the count it starts with
ALONE = HEAD + """
import scipy.special
print(json.dumps(blas()))
"""


def _run(code: str) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.endswith("_NUM_THREADS")}
    res = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                         text=True, check=True, env=env)
    return json.loads(res.stdout.strip().splitlines()[-1])


def _as_without_the_door(after: dict, before: dict) -> None:
    """``after`` (the caller's view after its door calls): the libraries the caller saw at its
    limit as before; the one loaded inside the calls at its count when loaded alone."""
    alone = _run(ALONE)
    for lib, n in after.items():
        assert n == (before[lib] if lib in before else alone[lib]), (lib, after, before, alone)


def test_a_library_loaded_inside_a_door_call_runs_on_one_thread_until_the_call_ends():
    out = _run(FIRST_INSIDE)
    assert out["scipy after a plain call"] is False  # the guard imports no scipy
    assert len(out["plain call"]) == 1 and set(out["plain call"].values()) == {1}  # numpy's
    assert set(out["caller before"].values()) == {min(2, os.cpu_count() or 1)}
    inner = out["inner, after scipy came in"]
    assert len(inner) == 2, inner  # numpy's and scipy's own
    assert set(inner.values()) == {1}, inner
    assert set(out["outer, after the inner call"].values()) == {1}  # not restored too early
    assert out["caller after"].keys() == inner.keys()
    _as_without_the_door(out["caller after"], out["caller before"])  # restored
    assert set(out["again, inside"].values()) == {1}


def test_scipy_imported_before_the_call_has_its_blas_limited_inside_it():
    out = _run(SCIPY_BEFORE)
    assert len(out["loaded before"]) == 1  # `import scipy` alone: numpy's BLAS only
    assert len(out["inside"]) == 2 and set(out["inside"].values()) == {1}, out["inside"]
    _as_without_the_door(out["caller after"], out["caller numpy's"])


def test_where_loaded_objects_cannot_be_listed_the_guard_loads_scipys_blas_first(monkeypatch):
    """Without /proc/self/maps (not Linux) no library can be seen arriving, so the guard
    imports scipy.linalg before it looks, as it always did: every BLAS on one thread inside."""
    from threadpoolctl import threadpool_info
    from vifpk.harness.door import boundary as B

    monkeypatch.setattr(B, "MAPS", "/nonexistent/maps")
    monkeypatch.setattr(B, "_CTL", [None, None])

    @B.boundary
    def call():
        return {i["filepath"]: i["num_threads"] for i in threadpool_info()
                if i["user_api"] == "blas"}

    inside = call()
    assert "scipy.linalg" in sys.modules and B._CTL[1] is None
    loaded = {i["filepath"] for i in threadpool_info() if i["user_api"] == "blas"}
    assert inside.keys() == loaded and set(inside.values()) == {1}, inside
