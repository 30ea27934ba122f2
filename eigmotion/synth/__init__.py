"""Data the product does not need at run time: the authored basic motions, synthetic
scenes and the benchmarks' query clips.
"""
