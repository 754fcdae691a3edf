"""A pytest plugin that appends every test phase's duration to $DURLOG as it completes, so a run
killed by a timeout still leaves its times (pytest's --durations prints only at the end).

    DURLOG=/tmp/dur.log PYTHONPATH=docs/scripts python -m pytest -p durlog ...

Each line: seconds, phase (setup/call/teardown), node id, outcome. Under xdist the controller
and the worker both log a report, so every line appears twice (deduplicate on id and phase).
"""

import os


def pytest_runtest_logreport(report):
    path = os.environ.get("DURLOG")
    if path:
        with open(path, "a") as f:
            f.write(f"{report.duration:.2f} {report.when} {report.nodeid} {report.outcome}\n")
