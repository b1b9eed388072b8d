"""Trajectory: what the robot really does with a toolpath (controller model, kinematics, estimate).

Kernels (no engine imports): `profile` (robot constants from data/robots/*.json), `blend` (corner
blending geometry), `speedplan` (junction speeds + jerk-limited span profiles along arc length), `simulate` (the
controller model, `SimulationResult`), `kinematics` (Pinocchio IK, joint limits, speed caps),
`calibrate` (fit a profile to a measured trace or to summary figures), `estimate` (the study's
closed-form cycle-time model), `study` (the study's objective-rectangle programs).
"""
