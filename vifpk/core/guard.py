"""A model plugin's failures are the plugin's: named, located, one line (issue 28).

vifpk calls code it did not write when a model comes from another distribution's entry point
(docs/plugins.md): importing the module, calling the factory, and the model's methods. What
that code raises, or returns out of protocol, is reported as a :class:`PluginError` naming the
plugin, the distribution that registered it, its source file and the line that raised -- not as
a vifpk "internal error", not as a numerical failure of the scene. ``SystemExit`` raised there
(a ``sys.exit`` in a plugin) becomes a PluginError too: vifpk never exits 0 on a plugin's
behalf. Ctrl-C (KeyboardInterrupt) passes through.

Checked on every call of a guarded model (``A`` the amplitudes asked, A > 0 where values must
be finite; at A = 0 a model may give inf or NaN, e.g. dividing by g(0) = 0):

- ``drift``, ``diffusion``, ``period``: one real number per amplitude (the shape of ``A``);
  finite where A > 0; ``diffusion`` >= 0 and ``period`` > 0 there;
- ``log_stationary_parts``: three arrays of that shape; ``q`` finite where A > 0.

vifpk's own models are not wrapped (their numbers stay bit for bit what the solvers compute).
"""

from __future__ import annotations

import contextlib
import sys
import traceback
from pathlib import Path
from typing import Any

import numpy as np


class PluginError(RuntimeError):
    """A model plugin failed or broke the protocol: exit 3, one line naming the plugin.
    ``model``: the registered name (a sweep point keeps the other models' numbers)."""

    def __init__(self, message: str, model: str | None = None) -> None:
        super().__init__(message)
        self.model = model


def plugin_stdout() -> contextlib.AbstractContextManager[Any]:
    """While a plugin's code runs, what it prints goes to the standard error (issue 39, G05: a
    model that prints must not corrupt ``--json -`` on the standard output). Python-level
    writes only (``print``, ``sys.stdout``); a C extension writing to file descriptor 1
    directly is not caught."""
    return contextlib.redirect_stdout(sys.stderr)


def _where(exc: BaseException, source: str | None) -> str:
    """'file.py:LINE' of the deepest frame in the plugin's source (else the deepest frame)."""
    frames = traceback.extract_tb(exc.__traceback__)
    if not frames:
        return ""
    mine = [f for f in frames if source and Path(f.filename).resolve() == Path(source)]
    f = (mine or frames)[-1]
    return f"{Path(f.filename).name}:{f.lineno}"


def describe(exc: BaseException, source: str | None) -> str:
    """'raised TypeError: text (file.py:12)', or 'called sys.exit(0)' for a SystemExit."""
    if isinstance(exc, SystemExit):
        return f"called sys.exit({exc.code!r})"
    text = str(exc).splitlines()[0][:200] if str(exc) else ""
    at = _where(exc, source)
    return f"raised {type(exc).__name__}: {text}" + (f" ({at})" if at else "")


def source_of(module: str) -> str | None:
    """The file of a plugin's module, found without importing it or its parent packages (None
    when it cannot be found). ``importlib.util.find_spec("pkg.mod")`` imports ``pkg``, so a
    plugin's code ran during input validation, outside the plugin guard (issue 38); here each
    level is looked up by the import system's finders (``sys.meta_path``) in the locations its
    parent's spec names, and no module is executed. A finder that cannot answer (ImportError)
    means no file to name."""
    import sys

    spec = None
    locations = None
    parts = module.split(".")
    for i in range(len(parts)):
        name = ".".join(parts[:i + 1])
        loaded = sys.modules.get(name)
        spec = getattr(loaded, "__spec__", None) if loaded is not None else None
        if spec is None:
            spec = _find(name, locations)
        if spec is None:
            return None
        locations = spec.submodule_search_locations
        if locations is None and i < len(parts) - 1:
            return None  # a module, not a package, where a package was named
    return str(Path(spec.origin).resolve()) if spec is not None and spec.origin else None


def _find(name: str, locations: Any) -> Any:
    """The spec the first meta-path finder gives for ``name`` (None: none has it)."""
    import sys

    for finder in sys.meta_path:
        find = getattr(finder, "find_spec", None)
        if find is None:
            continue
        try:
            spec = find(name, locations, None)
        except ImportError:
            return None
        if spec is not None:
            return spec
    return None


class GuardedModel:
    """A plugin's model object, its protocol methods checked (module docstring); every other
    attribute is the model's own."""

    _METHODS = ("drift", "diffusion", "period", "log_stationary_parts")

    def __init__(self, model: Any, label: str, source: str | None,
                 name: str | None = None) -> None:
        self._model, self._label, self._source, self._name = model, label, source, name

    def __getattr__(self, name: str) -> Any:
        value = getattr(self._model, name)  # AttributeError when the model has none
        if name in self._METHODS and callable(value):
            return lambda A, _f=value, _n=name: self._call(_n, _f, A)
        return value

    def __repr__(self) -> str:
        return f"GuardedModel({self._model!r})"

    @property
    def plugin_label(self) -> str:
        """'model plugin NAME (from DIST, FILE)': how messages name the plugin."""
        return self._label

    @property
    def plugin_name(self) -> str | None:
        """The plugin's registered name (PluginError.model)."""
        return self._name

    def _fail(self, what: str) -> PluginError:
        return PluginError(f"{self._label}: {what}", self._name)

    def _call(self, name: str, fn: Any, A: Any) -> Any:
        A = np.asarray(A, dtype=float)
        given = A.view()
        given.flags.writeable = False  # a plugin writing into A would change vifpk's grid
        try:
            with plugin_stdout():
                out = fn(given)
        except (KeyboardInterrupt, GeneratorExit):
            raise
        except BaseException as exc:  # noqa: BLE001 - the plugin's, named as such
            raise self._fail(f"{name}(A) {describe(exc, self._source)}") from exc
        if name == "log_stationary_parts":
            if not isinstance(out, tuple | list) or len(out) != 3:
                raise self._fail(f"{name}(A) returned {type(out).__name__}; it must return "
                                 "three arrays (q, log_pre, log_phase_pre)")
            parts = [self._values(name, part, A, label) for part, label in
                     zip(out, ("q", "log_pre", "log_phase_pre"), strict=True)]
            self._finite(name, parts[0], A, "q")
            return tuple(parts)
        values = self._values(name, out, A)
        self._finite(name, values, A)
        positive = A > 0
        if name == "diffusion" and np.any(values[positive] == 0):
            at = A[positive][values[positive] == 0][0]
            raise self._fail(f"diffusion(A) is zero at A = {at:.4g}; sigma^2(A) must be > 0 "
                             "for A > 0 (the stationary law divides by it; issue 39, G09)")
        if name == "diffusion" and np.any(values[positive] < 0):
            at = A[positive][values[positive] < 0][0]
            raise self._fail(f"diffusion(A) is negative at A = {at:.4g} "
                             f"({values[positive][values[positive] < 0][0]:.3g}); sigma^2(A) "
                             "must be >= 0")
        if name == "period" and np.any(values[positive] <= 0):
            at = A[positive][values[positive] <= 0][0]
            raise self._fail(f"period(A) is not positive at A = {at:.4g} "
                             f"({values[positive][values[positive] <= 0][0]:.3g})")
        return values

    def _values(self, name: str, out: Any, A: Any, part: str = "") -> Any:
        what = f"{name}(A)" + (f"'s {part}" if part else "")
        if np.iscomplexobj(out):
            raise self._fail(f"{what} returned complex numbers; it must return real ones")
        try:
            values = np.asarray(out, dtype=float)
        except (TypeError, ValueError):
            raise self._fail(f"{what} returned {type(out).__name__}, not numbers") from None
        if values.shape != A.shape:
            got = "a single value" if values.ndim == 0 else f"shape {values.shape}"
            raise self._fail(f"{what} returned {got} for {A.size} amplitudes (shape "
                             f"{A.shape}); it must return one value per amplitude")
        return values

    def _finite(self, name: str, values: Any, A: Any, part: str = "") -> None:
        bad = (A > 0) & ~np.isfinite(values)
        if np.any(bad):
            what = f"{name}(A)" + (f"'s {part}" if part else "")
            raise self._fail(f"{what} is {values[bad][0]} at A = {A[bad][0]:.4g}; it must be "
                             "finite for A > 0")


def guard(model: Any, label: str, source: str | None, name: str | None = None
          ) -> GuardedModel:
    """The plugin's model checked on every protocol call; a factory's result without
    ``drift`` and ``diffusion`` is refused here."""
    for attr in ("drift", "diffusion"):
        if not callable(getattr(model, attr, None)):
            raise PluginError(f"{label}: its factory returned {type(model).__name__}, "
                              f"which has no {attr}(A) (the averaged-model protocol, "
                              "docs/plugins.md)", name)
    return GuardedModel(model, label, source, name)
