"""3D pose from one camera: the matched motion aligned to the clip frame by frame, and
the replay video.
"""
