"""The command line (``vifpk``): ``app`` builds the parser and maps errors to exit codes,
``commands`` runs the stationary commands, ``timedomain`` the passage and transient ones,
``options`` holds the option types and helpers they share.
"""
