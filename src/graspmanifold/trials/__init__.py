"""Trials and what is counted over them: grid poses, one trial, N trials at once, statistics, the
evaluation over a grid, the experience study, the benchmark, and the contracts of the library's
interfaces as checks.
"""
