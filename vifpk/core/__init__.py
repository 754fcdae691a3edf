"""vifpk's shared vocabulary: the words every package uses, with no physics.

The scene schema (:mod:`vifpk.core.scene`) lives here; so do the registries, the result and
status types, the warning records and every default that more than one module uses (one home:
a list or default written twice is a bug), and the plumbing every layer shares without physics:
atomic file writes and figures (``io``) and the run's provenance block (``provenance``). Every
package may import ``vifpk.core``; the solvers (``averaging``, ``fpk``, ``montecarlo``) import
nothing else of ours. ``vifpk.core`` imports no solver and nothing of ``harness``
(tests/test_architecture.py checks both, the second in a fresh interpreter).
"""
