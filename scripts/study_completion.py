"""The completion study (issue 68): a thin command over `graspmanifold.studies.completion`."""

from graspmanifold.studies.completion import main

if __name__ == "__main__":
    main()
