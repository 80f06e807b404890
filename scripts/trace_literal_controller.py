"""Why the literal controller loses where the blend holds: a thin command over `graspmanifold.studies.recall_trace`."""

from graspmanifold.studies.recall_trace import main

if __name__ == "__main__":
    main()
