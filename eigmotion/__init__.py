"""eigmotion: 3D human motion from one uncalibrated camera.

Stages, one module each, data flowing one way::

    bvh / asf / amc → motion → kinematics → naming → avatar → cameras → silhouettes
    → motion_image → eigenspace → keys → store → database → cli

and beside them the silhouette-dictionary tracker.
"""

__version__ = "0.1.0"
