"""Sweeps: one workflow at every point of a parameter grid, on any executor.

``spec`` reads and checks a sweep file; ``points`` is one point (key, seed, job, the workflow
run at it); ``executors`` runs points serially, in processes or on dask; ``store`` keeps each
finished point's record (resume); ``runs`` drives a sweep, plain or adaptive (``adaptive``: the
refinement's geometry); ``dataset`` assembles sweep.nc; ``maps`` draws it; ``timesweep`` holds
what passage and transient sweeps add. docs/maps.md.
"""
