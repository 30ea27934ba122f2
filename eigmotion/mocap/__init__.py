"""Motion capture: the motion type, rotations, forward kinematics, joint names, the
canonical skeleton, BVH and ASF/AMC files, and the basic-motion library.
"""
