"""Virtual cameras and pictures: camera rigs, rasterised and GL rendering, silhouettes,
video and image files, figures.
"""
