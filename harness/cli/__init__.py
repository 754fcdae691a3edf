"""The command line (``vifpk``): ``app`` builds the parser from the registered workflows and
maps errors to exit codes, ``arguments`` holds the built-in workflows' argparse builders (named
by their records in harness/workflows), ``commands`` runs the stationary commands,
``timedomain`` the passage and transient ones, ``options`` holds the option types and helpers
they share, ``entry`` is the console script's first lines.
"""
