"""The community's Shadow Hands beside ours (issue 28): a thin command over `graspmanifold.studies.hands`."""

from graspmanifold.studies.hands import main

if __name__ == "__main__":
    main()
