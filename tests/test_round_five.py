"""Hardening, round five (issue 69): each case of RELIABILITY.md's round-five table, bad ones first; every test
failed before its fix."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

import graspmanifold as gm
from graspmanifold.control.protocols import DEXGRASPBENCH, PhysicsProfile, Protocol, pushed
from graspmanifold.control.judge import JUDGING
from graspmanifold.control.stages import JudgingRules


# bad 2: judging rules were never checked (a NaN stiffness, a negative hold ran to hold 100 %)
@pytest.mark.parametrize("field, value, message", [
    ("support_stiffness", math.nan, r"JudgingRules\.support_stiffness must be a finite number >= 0"),
    ("hold_seconds", -1.0, r"JudgingRules\.hold_seconds must be a finite number > 0"),
    ("hold_limit", 0.0, r"JudgingRules\.hold_limit must be a finite number > 0"),
    ("epsilon_threshold", math.inf, r"JudgingRules\.epsilon_threshold"),
    ("margin", "yes", r"JudgingRules\.margin must be True or False"),
    ("lift_speed", True, r"JudgingRules\.lift_speed must be a finite number"),
    ("stages", (), r"JudgingRules\.stages must be a non-empty tuple"),
])
def test_judging_rules_are_checked_when_made(field, value, message):
    with pytest.raises(gm.InvalidInput, match=message):
        JudgingRules(**{field: value})
    with pytest.raises(gm.InvalidInput, match=message):  # a protocol of one's own is made of them
        Protocol("mine", replace(JUDGING, **{field: value}))


# bad 3: a test of zero length passed every grasp
@pytest.mark.parametrize("field, value, message", [
    ("hold_chunks", 0, r"DexGraspBenchProtocol\.hold_chunks must be a whole number >= 1"),
    ("steps_per_chunk", 2.5, r"DexGraspBenchProtocol\.steps_per_chunk must be a whole number"),
    ("directions", (), r"DexGraspBenchProtocol\.directions must hold at least one direction"),
    ("force_per_kg", math.nan, r"DexGraspBenchProtocol\.force_per_kg"),
    ("translation_limit", -0.05, r"DexGraspBenchProtocol\.translation_limit"),
])
def test_a_push_test_that_tests_nothing_is_refused(field, value, message):
    with pytest.raises(gm.InvalidInput, match=message):
        pushed(replace(DEXGRASPBENCH, **{field: value}))


def test_judging_directions_are_unit_vectors():
    """Poor: directions=() ended in an IndexError in stages.py; a direction of length 2 doubled the push."""
    with pytest.raises(gm.InvalidInput, match=r"JudgingRules\.directions must hold at least one direction"):
        JudgingRules(directions=())
    with pytest.raises(gm.InvalidInput, match=r"JudgingRules\.directions must be unit vectors"):
        JudgingRules(directions=((2.0, 0.0, 0.0),))
    assert JudgingRules(directions=[[0, 0, 1]]).directions == ((0.0, 0.0, 1.0),)


@pytest.mark.parametrize("field, value, message", [
    ("timestep", 0.0, r"PhysicsProfile\.timestep must be a finite number > 0"),
    ("integrator", "leapfrog", r"PhysicsProfile\.integrator must be one of"),
    ("condim", 5, r"PhysicsProfile\.condim must be one of"),
    ("friction", (0.6,), r"PhysicsProfile\.friction must be \(sliding, torsional\)"),
    ("friction", (-0.6, 0.02), r"PhysicsProfile\.friction\[0\]"),
    ("object_mass", 0.0, r"PhysicsProfile\.object_mass"),
    ("gravity", "off", r"PhysicsProfile\.gravity must be True or False"),
])
def test_a_physics_profile_is_checked_when_made(field, value, message):
    """Poor: a push physics with timestep=0 ended in a ZeroDivisionError in trial.py."""
    with pytest.raises(gm.InvalidInput, match=message):
        replace(DEXGRASPBENCH.physics, **{field: value})
    assert isinstance(replace(DEXGRASPBENCH.physics, timestep=0.002), PhysicsProfile)


def test_one_mechanism_checks_every_configuring_value():
    """The controller's, the regrasp's and the judging's settings say their ranges alike."""
    for make, message in ((lambda: gm.ControllerParams(closing_rate=math.nan), r"ControllerParams\.closing_rate"),
                          (lambda: gm.Regrasp(probe_seconds=-1.0), r"Regrasp\.probe_seconds"),
                          (lambda: JudgingRules(push=-1.0), r"JudgingRules\.push")):
        with pytest.raises(gm.InvalidInput, match=message + r" must be a finite number >[=]? 0"):
            make()
