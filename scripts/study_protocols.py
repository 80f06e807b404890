"""Our grasps judged the way the field judges them: DexGraspBench's protocol beside our hold test.

A thin command over `graspmanifold.studies.protocols`, whose docstring says what it runs and writes; `--help` lists
its options.
"""

from graspmanifold.studies.protocols import main

if __name__ == "__main__":
    main()
