"""The uncertainty study: when the object is not where the plan assumed, does closing the grasp on touch beat
executing the plan open loop?

A thin command over `graspmanifold.studies.uncertainty`, whose docstring says what it runs and writes; `--help` lists
its options.
"""

from graspmanifold.studies.uncertainty import main

if __name__ == "__main__":
    main()
