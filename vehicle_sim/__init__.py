"""Terregator/Navlab simulator: world, kinematics, colored-range sensors, drive interface.

Knows nothing about the blackboard.
"""
