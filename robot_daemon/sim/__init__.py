"""Interbot simulator: a deterministic, simulated-clock stand-in for the robot's hardware.

Replaces the RoboteQ motor controller and encoders (``diff_drive``, ``odometry_model``), the
Hokuyo UTM-30LX (``laser_sim``), the Logitech camera (``camera_sim``) and the BMS (``battery``)
of thesis §4.1, in an office built from a map_server map plus furniture and walking people
(``world``, ``people``). ``simulator.Simulator`` ties them together. No Qt, no zenoh, no wall clock.
"""
