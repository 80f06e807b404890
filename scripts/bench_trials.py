"""Benchmark grasp trials: the batched CPU backend against one trial at a time, and the Warp backend.

A thin command over `graspmanifold.studies.trial_speed`, whose docstring says what it runs and writes; `--help` lists
its options.
"""

from graspmanifold.studies.trial_speed import main

if __name__ == "__main__":
    main()
