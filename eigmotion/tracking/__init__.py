"""The silhouette-dictionary pose tracker (multi-camera), after Okada et al., Toshiba.

Offline, a posture dictionary is built from mocap (:mod:`.dictionary`) and the body
model is posed in every posture (:mod:`.body`).  Online, per set of views: the
person's 3D position from the silhouettes' centroids (:mod:`.position`), candidate
postures near the previous one, their silhouettes scored against the observed ones
(:mod:`.similarity`, :mod:`.frame_scoring`; postures facing away from the direction
of travel penalised, :mod:`.heading`) through the 2-layer search tree
(:mod:`.search`), all driven by :class:`~.tracker.SilhouetteTracker`; optionally a
Viterbi path through each frame's best postures over the whole clip
(:mod:`.temporal`).  Where the pose network's landmarks of every camera are at hand,
the keypoints stage triangulates them (:mod:`.triangulation`) and fits each estimate
to the joints (:mod:`.keypoint_fit`).  Smooth output
motion comes from variable-speed playback of a reference sequence
(:mod:`.generation`).  Cameras come from a calibration file or from checkerboard
images (:mod:`.calibration`).

The tracker stands beside the retrieval stages and does not use the motion database.
"""

from eigmotion.tracking.body import PostureBodies, avatar_bodies, proxy_bodies
from eigmotion.tracking.calibration import (
    Calibration,
    CameraPair,
    calibrate_camera,
    calibrate_cameras,
    load_calibration,
    load_cameras,
    save_calibration,
)
from eigmotion.tracking.dictionary import (
    PostureDictionary,
    PostureSequence,
    build_dictionary,
    dictionary_from_motion,
    dictionary_from_sequences,
    posture_sequence,
    select_candidates,
)
from eigmotion.tracking.generation import (
    VariableSpeedPlayback,
    playback_motion,
    variable_speed_playback,
)
from eigmotion.tracking.heading import facing_deg, travel_headings
from eigmotion.tracking.keypoint_fit import FittedPoses, KeypointFitter
from eigmotion.tracking.position import intersect_plane_lines, locate, mask_centroid, select_pair
from eigmotion.tracking.postures import d1_distance, d2_distance
from eigmotion.tracking.search import (
    beam_search,
    build_cluster_tree,
    build_two_layer_tree,
    exhaustive_search,
    two_layer_search,
)
from eigmotion.tracking.similarity import score_masks, similarity
from eigmotion.tracking.tracker import Estimate, SilhouetteTracker, TrackerConfig, TrackResult
from eigmotion.tracking.triangulation import (
    TriangulatedJoints,
    TriangulationConfig,
    triangulate_clip,
    triangulate_points,
)

__all__ = [
    "Calibration",
    "CameraPair",
    "Estimate",
    "FittedPoses",
    "KeypointFitter",
    "PostureBodies",
    "PostureDictionary",
    "PostureSequence",
    "SilhouetteTracker",
    "TrackResult",
    "TrackerConfig",
    "TriangulatedJoints",
    "TriangulationConfig",
    "VariableSpeedPlayback",
    "avatar_bodies",
    "beam_search",
    "build_cluster_tree",
    "build_dictionary",
    "build_two_layer_tree",
    "calibrate_camera",
    "calibrate_cameras",
    "d1_distance",
    "d2_distance",
    "dictionary_from_motion",
    "dictionary_from_sequences",
    "exhaustive_search",
    "facing_deg",
    "intersect_plane_lines",
    "load_calibration",
    "load_cameras",
    "locate",
    "mask_centroid",
    "playback_motion",
    "posture_sequence",
    "proxy_bodies",
    "save_calibration",
    "score_masks",
    "select_candidates",
    "select_pair",
    "similarity",
    "travel_headings",
    "triangulate_clip",
    "triangulate_points",
    "two_layer_search",
    "variable_speed_playback",
]
