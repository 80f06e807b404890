"""The palm that follows touch (issue 66): a thin command over `graspmanifold.studies.palm`."""

from graspmanifold.studies.palm import main

if __name__ == "__main__":
    main()
