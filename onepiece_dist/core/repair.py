"""Mesh repairs as real assets need them, each pure numpy and said in the object's ingest record.

- :func:`weld`: vertices split at UV seams (a textured scan stores a position once per texture chart) or
  duplicated, merged at 0.1 micrometre, so that faces share their edges again;
- :func:`connected_pieces`: how many disconnected pieces the faces form (kept as parts of one rigid object);
- :func:`boundary_edges` and :func:`closed_volume`: an open surface's volume with every hole capped by a fan from
  the hole's centroid (a scan open at its base gets its base back), for the object's mass. The surface the gripper
  crops stays the original one: caps only enter the volume;
- :func:`fan_fill`: the same caps as triangles, for a reconstructed scan that must come out watertight
  (objects.supplement).

Only additions and products (no transcendental functions), so every CPU gives the same volume.
"""

from __future__ import annotations

import numpy as np

WELD_STEP = 1e-7  # m: positions equal when rounded to 0.1 micrometre (the content id's rounding)


def weld(vertices: np.ndarray, faces: np.ndarray, step: float = WELD_STEP) -> tuple[np.ndarray, np.ndarray, int]:
    """Vertices at the same position (to ``step``) merged, in order of first appearance; faces that collapse
    (two corners merged) dropped. -> (vertices (k, 3), faces (m', 3) int64, vertices merged). A mesh with no
    duplicate comes back unchanged (the same arrays)."""
    keys = np.round(np.asarray(vertices, dtype=np.float64) / step).astype(np.int64)
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    if len(first) == len(vertices):
        return vertices, faces, 0
    order = np.argsort(first, kind="stable")  # unique rows in order of their first appearance
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    welded = rank[inverse.ravel()][np.asarray(faces, dtype=np.int64)]
    keep = (welded[:, 0] != welded[:, 1]) & (welded[:, 1] != welded[:, 2]) & (welded[:, 0] != welded[:, 2])
    return np.asarray(vertices)[np.sort(first)], welded[keep], len(vertices) - len(first)


def connected_pieces(faces: np.ndarray, vertex_count: int) -> int:
    """How many pieces the faces form (faces joined through shared vertices; unused vertices ignored)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    faces = np.asarray(faces, dtype=np.int64)
    rows, cols = np.repeat(faces[:, 0], 3), faces.ravel()
    graph = coo_matrix((np.ones(len(rows), dtype=np.int8), (rows, cols)), shape=(vertex_count, vertex_count))
    _, label = connected_components(graph, directed=False)
    return len(np.unique(label[faces[:, 0]]))


def boundary_edges(faces: np.ndarray) -> np.ndarray:
    """(e, 2) int64 directed edges (a, b), as their faces traverse them, that no other face shares: the rims of
    an open surface's holes. Empty for a closed (watertight) mesh."""
    faces = np.asarray(faces, dtype=np.int64)
    directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    undirected = np.sort(directed, axis=1)
    _, inverse, counts = np.unique(undirected, axis=0, return_inverse=True, return_counts=True)
    return directed[counts[inverse.ravel()] == 1]


def closed_volume(vertices: np.ndarray, faces: np.ndarray) -> tuple[float, int]:
    """The volume (m^3, signed: negative when wound inwards) of the solid the faces bound once every hole is
    capped by a fan from the centroid of its rim, and how many holes were capped. Exact for a closed mesh (no
    cap) and for holes whose rims are planar and star-shaped about their centroid."""
    vertices = np.asarray(vertices, dtype=np.float64)
    tri = vertices[np.asarray(faces)]
    volume = float(np.sum(np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2]))))
    rims = boundary_edges(faces)
    if len(rims) == 0:
        return volume / 6.0, 0
    hole, holes = _rim_components(rims, len(vertices))
    apex = np.zeros((holes, 3))
    used = np.unique(rims[:, 0])
    np.add.at(apex, hole[used], vertices[used])
    apex /= np.bincount(hole[used], minlength=holes)[:, None]
    a, b = vertices[rims[:, 0]], vertices[rims[:, 1]]  # the cap traverses each rim edge backwards: (b, a, apex)
    caps = np.einsum("ij,ij->i", b, np.cross(a, apex[hole[rims[:, 0]]]))
    return (volume + float(np.sum(caps))) / 6.0, holes


def _rim_components(rims: np.ndarray, vertex_count: int) -> tuple[np.ndarray, int]:
    """(vertex_count,) the hole each rim vertex belongs to (connected through rim edges), and how many holes."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    graph = coo_matrix((np.ones(len(rims), dtype=np.int8), (rims[:, 0], rims[:, 1])),
                       shape=(vertex_count, vertex_count))
    _, label = connected_components(graph, directed=False)
    on_rim = np.unique(rims.ravel())
    ids, dense = np.unique(label[on_rim], return_inverse=True)
    hole = np.full(vertex_count, -1, dtype=np.int64)
    hole[on_rim] = dense.ravel()
    return hole, len(ids)


def fan_fill(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """vertices (V, 3), faces (F, 3) -> the same plus one centroid vertex and a fan per boundary loop,
    wound to match the surrounding faces."""
    directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]).astype(np.int64)
    n = len(vertices)
    keys = directed[:, 0] * n + directed[:, 1]
    boundary = directed[~np.isin(keys, directed[:, 1] * n + directed[:, 0])]
    if len(boundary) == 0:
        return vertices, faces
    following: dict[int, list[int]] = {}
    for a, b in boundary.tolist():
        following.setdefault(a, []).append(b)
    extra_vertices, extra_faces = [], []
    for loop in _walk_loops(following):
        centre = n + len(extra_vertices)
        extra_vertices.append(vertices[loop].mean(axis=0))
        extra_faces += [[b, a, centre] for a, b in zip(loop, loop[1:] + loop[:1], strict=True)]
    return np.vstack([vertices, extra_vertices]), np.vstack([faces, np.asarray(extra_faces, dtype=faces.dtype)])


def _walk_loops(following: dict[int, list[int]]) -> list[list[int]]:
    """Closed vertex loops of directed boundary edges {start: [ends]}; a vertex where two loops touch is
    walked once per loop. Walks that do not close are dropped (the watertight check then refuses)."""
    loops = []
    while following:
        start = next(iter(following))
        loop, current = [start], start
        while following.get(current):
            ends = following[current]
            following_vertex = ends.pop()
            if not ends:
                del following[current]
            if following_vertex == start:
                loops.append(loop)
                break
            loop.append(following_vertex)
            current = following_vertex
    return loops
