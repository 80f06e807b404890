"""DexGraspBench's protocol beside our hold test: a thin command over `graspmanifold.studies.protocols`."""

from graspmanifold.studies.protocols import main

if __name__ == "__main__":
    main()
