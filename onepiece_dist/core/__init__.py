"""Pure geometry on numpy arrays: frames, meshes, sampling, voxel codes, dedup.

Nothing here imports a simulator, a store, Ray or torch (a test checks ``sys.modules``).
"""
