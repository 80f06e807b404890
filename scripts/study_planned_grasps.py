"""The planned-grasp study: a thin command over `graspmanifold.studies.planned_grasps`."""

from graspmanifold.studies.planned_grasps import main

if __name__ == "__main__":
    main()
