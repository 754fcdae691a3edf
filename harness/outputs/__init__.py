"""Outputs: what a run leaves behind, and how.

``outdir`` (output folders as units), ``signals`` (Ctrl-C and SIGTERM: stop, keep what is
finished), ``runwarnings`` (a run's RuntimeWarnings, counted for metrics.json), ``report`` and
``timereport`` (report.html/md and metrics.json of the check and of the time-domain workflows).
The file plumbing every layer writes with (atomic writes, JSON, figures) and the provenance
block are in ``vifpk.core`` (``io``, ``provenance``), below the workflows that write files.
"""
