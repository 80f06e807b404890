"""Does experience carry over to objects it was not built from? Paper experience on unseen objects.

A thin command over `graspmanifold.studies.unseen_objects`, whose docstring says what it runs and writes; `--help` lists
its options.
"""

from graspmanifold.studies.unseen_objects import main

if __name__ == "__main__":
    main()
