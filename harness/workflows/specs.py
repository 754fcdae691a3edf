"""The records of the built-in workflows that have no module of their own in this layer
(vifpk.core.protocols.Workflow; registered in pyproject.toml's ``vifpk.workflows``): ``solve``
(one solver through the door), ``sweep`` (harness/sweeps), ``models`` (a listing),
``averaging`` (a sweep's closed forms only), and the time domain's ``passage`` and
``transient`` (their workflows are harness/workflows/passage.py and transient.py). check,
bifurcation, figures and workprecision keep theirs beside their workflow (``SPEC``).

Each record names its parts by :class:`vifpk.core.protocols.Ref`: the argparse builders and
commands (harness/cli), the sweep points (harness/sweeps/points.py), the Python functions
(vifpk.api) and the tolerance tests (harness/testing.py) are imported when used, so loading
the registry imports none of them (tests/test_layers.py).
"""

from __future__ import annotations

from vifpk.core.protocols import Ref, WorkflowSpec

_CLI = "vifpk.harness.cli"
_POINTS = "vifpk.harness.sweeps.points"

SOLVE = WorkflowSpec(
    "solve", "solve one scene with one solver",
    add_arguments=Ref(f"{_CLI}.arguments:solve_arguments"),
    command=Ref(f"{_CLI}.commands:cmd_solve"), api=Ref("vifpk.api:solve"))
SWEEP = WorkflowSpec(
    "sweep", "run a workflow over a parameter grid (serial, process "
    "pool or dask) and write sweep.nc and maps",
    add_arguments=Ref(f"{_CLI}.arguments:sweep_arguments"),
    command=Ref(f"{_CLI}.commands:cmd_sweep"), api=Ref("vifpk.api:sweep"))
MODELS = WorkflowSpec(
    "models", "list the registered averaged models (built-in and "
    "plugins, docs/plugins.md)",
    add_arguments=Ref(f"{_CLI}.arguments:models_arguments"),
    command=Ref(f"{_CLI}.commands:cmd_models"))
PASSAGE = WorkflowSpec(
    "passage", "first passage out of A < Ac: reliability R(t), FPT density and MFPT of each "
    "averaged model against the original system",
    add_arguments=Ref(f"{_CLI}.timedomain:passage_arguments"),
    command=Ref(f"{_CLI}.timedomain:cmd_passage"),
    sweep_point=Ref(f"{_POINTS}:passage_point"), api=Ref("vifpk.api:passage"),
    assertion=Ref("vifpk.harness.testing:assert_mfpt_close"))
TRANSIENT = WorkflowSpec(
    "transient", "the law of the amplitude at given times from a start A0: each averaged model "
    "against the original system, and the relaxation times",
    add_arguments=Ref(f"{_CLI}.timedomain:transient_arguments"),
    command=Ref(f"{_CLI}.timedomain:cmd_transient"),
    sweep_point=Ref(f"{_POINTS}:transient_point"), api=Ref("vifpk.api:transient"),
    assertion=Ref("vifpk.harness.testing:assert_relaxation_close"))
AVERAGING = WorkflowSpec(
    "averaging", "the averaged models' closed forms only (sweeps; no subcommand: `vifpk solve "
    "--solver averaging` solves one scene)", sweep_point=Ref(f"{_POINTS}:averaging_point"))
