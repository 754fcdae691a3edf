"""The physics every solver reads (issue 37): what the system IS, written once.

A layer below the solvers: it imports ``vifpk.core`` only (and numpy; never numba). Each noise
kind (``noise/``) and impact law (``impact/``) is one declared object (vifpk.core.protocols),
registered by entry point; a solver asks for a kind's pieces with ``noise.pieces(kind,
solver)`` and for a law with ``impact.law(name, solver=)``, which raise in one line naming the
kind or law and the solver when it lacks a piece (no silent fallback to another kind).

The Monte Carlo's pieces are plain Python on floats and named tuples, written so that numba can
compile them: ``vifpk.montecarlo`` wraps them with its own ``jit`` (this package never imports
numba).
"""
