"""The paper, reproduced: its figures of maps, a verdict per claim, the report, and the resumable
pipeline behind `graspmanifold reproduce`.
"""
