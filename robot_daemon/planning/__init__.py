"""Navigation for the robot daemon: costmap, global A*, DWA local planner and the navigator.

The Python counterpart of the thesis's Hybrid Motion Planner (§3.3, §4.2.3.2); see each module.
"""
