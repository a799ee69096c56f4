"""Motion safety below the multiplexer: the collision monitor and assisted teleoperation.

NOT A CERTIFIED SAFETY SYSTEM. These are software guards on the laser scan that make driving
into walls and people much less likely; the emergency stop and the motor controller's watchdog
remain the safety functions and are unchanged by anything here.
"""
