"""The planned-grasp study: a grasp the controller knows, executed where the object is not quite where it was planned.

A thin command over `graspmanifold.studies.planned_grasps`, whose docstring says what it runs and writes; `--help`
lists its options.
"""

from graspmanifold.studies.planned_grasps import main

if __name__ == "__main__":
    main()
