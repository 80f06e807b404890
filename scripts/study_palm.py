"""The palm that follows touch (issue 66): a wrist the controller moves, on planned grasps and the paper's grid.

A thin command over `graspmanifold.studies.palm`, whose docstring says what it runs and writes; `--help` lists its
options.
"""

from graspmanifold.studies.palm import main

if __name__ == "__main__":
    main()
