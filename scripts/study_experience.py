"""The experience study (does recalled experience choose better grasps?): a thin command over its module."""

from graspmanifold.studies.experience_study import main

if __name__ == "__main__":
    main()
