"""The workflows: what a researcher asks, each built from the door's solvers.

``check`` (the three-way cross-check, its ``verdict`` and ``assumptions``), ``compare`` (metrics
and noise floors), ``tolerance`` (the error with the noise removed), ``bifurcation``,
``workprecision``, ``figures``, and the time domain: ``passage`` (first passage), ``survival``
(Kaplan-Meier), ``rarepassage`` (splitting), ``transient`` (relaxation). Each built-in
workflow's record (a WorkflowSpec registered in ``vifpk.workflows``) is here too: the ``SPEC`` of
check, bifurcation, figures and workprecision, and ``specs`` for the others.
"""
