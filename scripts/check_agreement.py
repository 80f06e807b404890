"""How far a published run's results move on this machine: a sample of its trials run again.

A thin command over `graspmanifold.studies.agreement`, whose docstring says what it runs and writes; `--help` lists
its options.
"""

from graspmanifold.studies.agreement import main

if __name__ == "__main__":
    main()
