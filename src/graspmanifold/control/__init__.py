"""Grasping: the four-phase tactile controller (one world, and as an array program over N), force
closure, the hold test, starting postures and the spring-based posture generator.
"""
