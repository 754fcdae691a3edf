"""The door to the solvers: the only harness package that imports ``vifpk.averaging``,
``vifpk.fpk`` or ``vifpk.montecarlo`` (tests/test_architecture.py). ``solvers`` runs the
stationary solvers, ``timedomain`` the first-passage and transient ones; both import nothing
of the harness.
"""
