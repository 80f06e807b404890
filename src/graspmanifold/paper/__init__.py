"""The paper, reproduced: its figures of maps, the typed run summary, a verdict per claim, the
report, and the resumable pipeline behind `graspmanifold reproduce`.
"""
