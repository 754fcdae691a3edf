"""The harness: scenes, running solvers, comparisons, reports and the command line.

It is the only package that knows all three solvers (averaging, fpk, montecarlo).
"""
