"""Why do the spring grasps of some shapes never hold? Each candidate's verification, taken apart.

A thin command over `graspmanifold.studies.spring_holds`, whose docstring says what it runs and writes; `--help` lists
its options.
"""

from graspmanifold.studies.spring_holds import main

if __name__ == "__main__":
    main()
