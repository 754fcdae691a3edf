"""numba's cache and the code a kernel inlines (montecarlo/_jit.py): numba judges a cached
kernel fresh by its own file only, so an edit of a piece it inlines (a noise kind's, an impact
law's, montecarlo/pieces.py) left the old compiled kernel running until the cache was deleted.
Every vifpk kernel's cache entry is now stamped with the contents of the code it may inline.

The end-to-end check compiles a one-line kernel ``vifpk._probe.kernel`` (a module of that name
loaded from a temporary file, so the stamped locator takes it) that inlines ``helper.piece``
from a second file, in a fresh process each time: a second process loads the first one's
cache; after the helper's file changes, a third recompiles and returns the new value.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from vifpk.montecarlo import _jit

KERNEL = """
from vifpk.montecarlo._jit import jit
from helper import piece

@jit
def kernel(x):
    return piece(x)
"""

RUN = """
import importlib.util, sys
sys.path.insert(0, {dir!r})
import vifpk.montecarlo._jit as j
from pathlib import Path
j._kernel_sources = lambda: [Path({helper!r})]   # the code this kernel inlines
j._STAMP.clear()   # (importing the package stamped its own kernels already)
spec = importlib.util.spec_from_file_location("vifpk._probe", {kernel!r})
mod = importlib.util.module_from_spec(spec)
sys.modules["vifpk._probe"] = mod
spec.loader.exec_module(mod)
print(mod.kernel(1.0), mod.kernel.stats.cache_hits and 1 or 0)
"""


def _run(tmp: Path) -> tuple[float, int]:
    code = RUN.format(dir=str(tmp), helper=str(tmp / "helper.py"), kernel=str(tmp / "probe.py"))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=300, check=True, env=None)
    value, hit = out.stdout.split()
    return float(value), int(hit)


def test_an_edit_of_an_inlined_piece_recompiles_the_cached_kernel(tmp_path: Path) -> None:
    (tmp_path / "probe.py").write_text(KERNEL)
    (tmp_path / "helper.py").write_text(
        "from numba import njit\n@njit(inline='always')\ndef piece(x):\n    return x + 1.0\n")
    assert _run(tmp_path) == (2.0, 0)   # compiled and cached
    assert _run(tmp_path) == (2.0, 1)   # loaded from the cache
    (tmp_path / "helper.py").write_text(
        "from numba import njit\n@njit(inline='always')\ndef piece(x):\n    return x + 2.0\n")
    assert _run(tmp_path) == (3.0, 0)   # the old entry is stale: recompiled (was 2.0, a hit)


def test_the_stamp_reads_the_physics_layer_and_the_registered_plugins() -> None:
    files = {p.as_posix() for p in _jit._kernel_sources()}
    for part in ("/montecarlo/pieces.py", "/montecarlo/lanes.py", "/physics/noise/ou.py",
                 "/physics/noise/bounded.py", "/physics/impact/johnson.py"):
        assert any(f.endswith(part) for f in files), part
    assert len(_jit.sources_stamp()) == 40


def test_other_functions_keep_numbas_own_locators() -> None:
    from numba.core.caching import CacheImpl

    stamped = [c for c in CacheImpl._locator_classes if c.__name__.startswith("Stamped")]
    assert stamped, "the stamped locators are installed on import"

    def outside(x):  # noqa: ANN001, ANN202 - a function of this test module
        return x

    assert all(c.from_function(outside, __file__) is None for c in stamped)


ALLOCATING = """
import numpy as np
from vifpk.montecarlo._jit import jit

@jit
def kernel(n):
    a = np.zeros(n)   # numba's runtime (NRT) allocates: it must be ready after a light load
    a[0] = 2.5
    return a[0] + a[n - 1] == 2.5
"""

HASHING = """
from vifpk.montecarlo._jit import jit

@jit
def kernel(n):
    # a string's hash reads numba's hash secrets, symbols registered by its registries
    return hash("vifpk" * n) == EXPECTED
"""

RUN_PROBE = """
import importlib.util, sys
import vifpk.montecarlo._jit as j
spec = importlib.util.spec_from_file_location("vifpk._probe2", {kernel!r})
mod = importlib.util.module_from_spec(spec)
sys.modules["vifpk._probe2"] = mod
spec.loader.exec_module(mod)
mod.EXPECTED = hash("vifpk" * 4)   # (frozen into the compiled code: PYTHONHASHSEED is fixed)
ok = mod.kernel(4)
print(int(ok), mod.kernel.stats.cache_hits and 1 or 0, int("numba.np.arraymath" in sys.modules))
"""


def test_a_cache_hit_loads_without_numbas_registry_refresh(tmp_path: Path) -> None:
    """A hit (montecarlo/_jit.py ``_light``) loads object code without numba's registry
    refresh: its lowering registries (numba.np.arraymath, whose BLAS check imports
    scipy.linalg) stay unimported and the loaded kernel still allocates through numba's
    runtime; an entry naming a symbol of ``_REFRESH_SYMBOLS`` (a string hash) is loaded after
    the refresh; a miss compiles as ever."""
    import os

    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"), "PYTHONHASHSEED": "7"}

    def run(source: str) -> list[str]:
        (tmp_path / "probe2.py").write_text(source)
        code = RUN_PROBE.format(kernel=str(tmp_path / "probe2.py"))
        return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              timeout=300, check=True, env=env).stdout.split()

    assert run(ALLOCATING) == ["1", "0", "1"]   # compiled: the compiler refreshed numba
    assert run(ALLOCATING) == ["1", "1", "0"]   # loaded: no refresh, the runtime allocates
    assert run(HASHING) == ["1", "0", "1"]
    assert run(HASHING) == ["1", "1", "1"]   # loaded after the refresh


def test_light_load_falls_back_to_numbas_own_when_its_private_api_differs(monkeypatch):
    """numba >= 0.59 is allowed and the light load reads numba's private cache API: where a
    name it reads is missing, the load is numba's own (its full refresh), not an error."""
    from numba.core import caching

    from montecarlo import _jit

    light = _jit._light()
    owner = next(c for c in light.__mro__ if "_guard_against_spurious_io_errors" in vars(c))
    monkeypatch.delattr(owner, "_guard_against_spurious_io_errors")
    seen = []
    monkeypatch.setattr(caching.FunctionCache, "load_overload",
                        lambda self, sig, ctx: seen.append(sig) or "numba's own load")
    cache = object.__new__(light)
    from numba.core.registry import cpu_target
    assert cache.load_overload("sig", cpu_target.target_context) == "numba's own load"
    assert seen == ["sig"]
