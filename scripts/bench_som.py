"""Benchmark the SOM's hot paths in the paper's setting, against MiniSom in the same run.

A thin command over `graspmanifold.studies.som_speed`, whose docstring says what it runs and writes; `--help` lists
its options.
"""

from graspmanifold.studies.som_speed import main

if __name__ == "__main__":
    main()
