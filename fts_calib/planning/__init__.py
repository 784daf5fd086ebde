"""Planning: calibration motions for a robot and a tool, sized to a target, checked and written.

Home pose, sweeps, stop-and-go, continuous and smooth motions, excitation, the jig a model needs, trajectory files.
"""
