"""Outputs: what a run leaves behind, and how.

``io`` (atomic writes, JSON), ``outdir`` (output folders as units), ``signals`` (Ctrl-C and
SIGTERM: stop, keep what is finished), ``provenance`` (which run made a file), ``report`` and
``timereport`` (report.html/md and metrics.json of the check and of the time-domain workflows).
"""
