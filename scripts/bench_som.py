"""Benchmark the SOM's hot paths against MiniSom: a thin command over `graspmanifold.studies.som_speed`."""

from graspmanifold.studies.som_speed import main

if __name__ == "__main__":
    main()
