"""The retrieval engine: motion images, the eigenspace, quantised keys, the B-tree
search, the ZODB store, silhouette sequences, the database build and queries.
"""
