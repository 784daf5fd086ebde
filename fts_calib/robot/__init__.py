"""Robot: definitions, joints, Kinematics, collision, orientation, inertia, the tool and the one wrench model.

Kinematics is the only forward kinematics. Knows nothing of channels or sources.
"""
