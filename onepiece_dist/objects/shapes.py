"""Seeded household-sized shapes to label on, with no file to fetch: the source ``shapes:groceries[a:b]`` and
``shapes:vessels[a:b]``.

- ``groceries``: boxes, cylinders, capsules and ellipsoids of the sizes groceries come in (2-9 cm across, 3-22 cm
  tall), in turn.
- ``vessels``: the household kinds those lack: flat packages (1-3.5 cm thin), cups with a handle, thin-walled
  bowls and bottles with a neck, in turn.

Shape ``k`` of a set draws its sizes from its own seeded generator, so a slice names the same shapes wherever it
is resolved. Each ref carries its sizes, and any worker builds the same mesh from them: every vertex comes from
additions, products and the portable sine (core.portable), the same bits on every CPU. Meshes are closed and
wound outwards. A cup is its body and a handle, two pieces of one rigid object.
"""

from __future__ import annotations

import numpy as np

from onepiece_dist.core.mesh import TriangleMesh, box_mesh, cylinder_mesh, make_mesh, merge_meshes, sphere_mesh
from onepiece_dist.core.portable import sin_cos

SET_SIZE = 1000  # shapes in each set: a slice beyond it is empty
SECTIONS = 32  # around the axis of a solid of revolution
SETS = {"groceries": (("box", "cylinder", "capsule", "ellipsoid"), 55),
        "vessels": (("flat_box", "cup", "bowl", "bottle"), 56)}  # set -> (kinds in turn, the seed's tag)


def shape_parameters(set_name: str, window: slice = slice(None)) -> list[tuple[str, str, tuple[float, ...]]]:
    """The shapes of ``set_name`` (a key of SETS) in ``window`` of its SET_SIZE: (name, kind, sizes in metres), in
    order."""
    kinds, tag = SETS[set_name]
    shapes = []
    for k in range(SET_SIZE)[window]:
        kind = kinds[k % len(kinds)]
        sizes = _SIZES[kind](np.random.default_rng([tag, k]))
        shapes.append((f"{set_name}/{kind}_{k:03d}", kind, tuple(round(float(s), 6) for s in sizes)))
    return shapes


def shape_mesh(kind: str, sizes: tuple[float, ...], name: str) -> TriangleMesh:
    """The closed, outward-wound mesh of one shape (``kind`` a key of _SIZES) in metres."""
    if kind in ("box", "flat_box"):
        return box_mesh(sizes, name=name)
    if kind == "cylinder":
        return cylinder_mesh(*sizes, sections=SECTIONS, name=name)
    if kind == "ellipsoid":
        sphere = sphere_mesh(1.0)
        return make_mesh(sphere.vertices * np.asarray(sizes), sphere.faces, name)
    return make_mesh(*_BUILDERS[kind](*sizes), name)


def _capsule(radius: float, length: float) -> tuple[np.ndarray, np.ndarray]:
    """A cylinder of ``length`` capped by hemispheres of ``radius``, along z from 0."""
    arc = np.linspace(-np.pi / 2, 0, 9)
    sin, cos = sin_cos(arc)
    cos[0] = 0.0  # the pole: on the axis
    lower = np.c_[radius * cos, radius + radius * sin]
    upper = np.c_[radius * cos[::-1], radius + length - radius * sin[::-1]]
    return revolved(np.vstack([lower, upper]))


def _cup(radius: float, height: float, wall: float) -> tuple[np.ndarray, np.ndarray]:
    """A cup: its body's profile revolved, and a ring handle on its side."""
    body = revolved(np.array([(0, 0), (radius, 0), (radius, height), (radius - wall, height),
                              (radius - wall, wall), (0, wall)]))
    handle_vertices, handle_faces = torus(height / 4, 0.005)
    handle_vertices = np.c_[handle_vertices[:, 0], -handle_vertices[:, 2], handle_vertices[:, 1]]  # ring in xz
    return merge_meshes([body, (handle_vertices + [radius, 0.0, height / 2], handle_faces)])


def _bowl(radius: float, height: float, wall: float, base: float) -> tuple[np.ndarray, np.ndarray]:
    return revolved(np.array([(0, 0), (base, 0), (radius, height), (radius - wall, height), (base - wall, wall),
                              (0, wall)]))


def _bottle(radius: float, height: float, neck: float, shoulder: float) -> tuple[np.ndarray, np.ndarray]:
    return revolved(np.array([(0, 0), (radius, 0), (radius, shoulder), (neck, shoulder + 2 * (radius - neck)),
                              (neck, height), (0, height)]))


def revolved(profile: np.ndarray, sections: int = SECTIONS) -> tuple[np.ndarray, np.ndarray]:
    """A solid of revolution about z: ``profile`` (n, 2) of (radius, height), from a point on the axis outwards
    and back to the axis (counter-clockwise in the half-plane), closed and wound outwards. -> (vertices, faces)"""
    sin, cos = sin_cos(np.arange(sections) * (2 * np.pi / sections))
    rings, vertices, count = [], [], 0
    for radius, height in profile:
        if radius == 0:  # on the axis: one vertex
            vertices.append([[0.0, 0.0, height]])
            rings.append(np.full(sections, count))
            count += 1
        else:
            vertices.append(np.c_[radius * cos, radius * sin, np.full(sections, height)])
            rings.append(count + np.arange(sections))
            count += sections
    faces = []
    for a, b in zip(rings[:-1], rings[1:], strict=True):
        a_next, b_next = np.roll(a, -1), np.roll(b, -1)
        faces += [np.c_[a, a_next, b_next], np.c_[a, b_next, b]]
    faces = np.vstack(faces)
    distinct = (faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])
    return np.vstack(vertices), faces[distinct]


def torus(major: float, minor: float, major_sections: int = 24,
          minor_sections: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """A ring about z centred at the origin, wound outwards. -> (vertices, faces)"""
    sin_u, cos_u = sin_cos(np.arange(major_sections) * (2 * np.pi / major_sections))
    sin_v, cos_v = sin_cos(np.arange(minor_sections) * (2 * np.pi / minor_sections))
    reach = major + minor * cos_v
    vertices = np.stack([np.outer(cos_u, reach), np.outer(sin_u, reach),
                         np.broadcast_to(minor * sin_v, (major_sections, minor_sections))], axis=-1)
    u, v = np.meshgrid(np.arange(major_sections), np.arange(minor_sections), indexing="ij")
    here, u_next, v_next = u * minor_sections + v, (u + 1) % major_sections, (v + 1) % minor_sections
    ahead, both, up = u_next * minor_sections + v, u_next * minor_sections + v_next, u * minor_sections + v_next
    faces = np.vstack([np.c_[here.ravel(), ahead.ravel(), both.ravel()],
                       np.c_[here.ravel(), both.ravel(), up.ravel()]])
    return vertices.reshape(-1, 3), faces


def _bottle_sizes(rng: np.random.Generator) -> tuple[float, ...]:
    radius, height = rng.uniform(0.02, 0.04), rng.uniform(0.12, 0.22)
    return radius, height, rng.uniform(0.009, 0.015), height * rng.uniform(0.55, 0.75)


def _bowl_sizes(rng: np.random.Generator) -> tuple[float, ...]:
    radius, height, wall = rng.uniform(0.04, 0.075), rng.uniform(0.03, 0.065), rng.uniform(0.003, 0.006)
    return radius, height, wall, radius * rng.uniform(0.4, 0.6)


_SIZES = {  # kind -> its sizes drawn from a generator
    "box": lambda rng: (rng.uniform(0.02, 0.09), rng.uniform(0.03, 0.12), rng.uniform(0.03, 0.22)),
    "cylinder": lambda rng: (rng.uniform(0.012, 0.045), rng.uniform(0.03, 0.2)),
    "capsule": lambda rng: (rng.uniform(0.012, 0.035), rng.uniform(0.02, 0.14)),
    "ellipsoid": lambda rng: tuple(rng.uniform([0.015, 0.015, 0.015], [0.05, 0.06, 0.08])),
    "flat_box": lambda rng: (rng.uniform(0.04, 0.1), rng.uniform(0.03, 0.09), rng.uniform(0.01, 0.035)),
    "cup": lambda rng: (rng.uniform(0.028, 0.045), rng.uniform(0.06, 0.11), rng.uniform(0.003, 0.006)),
    "bowl": _bowl_sizes,
    "bottle": _bottle_sizes,
}
SHAPE_KINDS = frozenset(_SIZES)
_BUILDERS = {"capsule": _capsule, "cup": _cup, "bowl": _bowl, "bottle": _bottle}
