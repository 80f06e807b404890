"""DexGraspBench's protocol beside our hold test: a thin command over `graspmanifold.studies.protocol_study`."""

from graspmanifold.studies.protocol_study import main

if __name__ == "__main__":
    main()
