"""People out of video: the silhouettes of a clip, with or without an image of the empty scene."""
