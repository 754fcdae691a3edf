"""The physics every solver reads (issue 37): what the system IS, written once.

A layer below the solvers: it imports ``vifpk.core`` only (and numpy; never numba). Each noise
kind (``noise/``) is one module declaring the pieces each solver needs of it; a solver asks for a
piece with ``noise.piece(kind, solver, name)``, which raises in one line naming the kind and the
solver when the module has none (no silent fallback to another kind).

The Monte Carlo's pieces are plain Python on floats and named tuples, written so that numba can
compile them: ``vifpk.montecarlo`` wraps them with its own ``jit`` (this package never imports
numba).
"""
