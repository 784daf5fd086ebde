"""Robot: robot definitions, Kinematics (the only forward kinematics), collision checks, the tool and its wrench.

Knows nothing of strains or feeds.
"""
