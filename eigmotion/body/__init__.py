"""The avatar: the skinned MakeHuman body, its garments, retargeting motions onto it,
and a proxy body of simple solids.
"""
