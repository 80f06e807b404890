"""The experience study: does recalling experience choose better grasps than fixed preshapes, once and with a regrasp?

A thin command over `graspmanifold.studies.experience`, whose docstring says what it runs and writes; `--help` lists
its options.
"""

from graspmanifold.studies.experience import main

if __name__ == "__main__":
    main()
