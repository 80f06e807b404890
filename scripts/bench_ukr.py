"""Benchmark the UKR manifold's training and completion: a thin command over `graspmanifold.studies.ukr_speed`."""

from graspmanifold.studies.ukr_speed import main

if __name__ == "__main__":
    main()
