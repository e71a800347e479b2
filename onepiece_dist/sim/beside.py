"""Other objects on the pick world's table beside the one it picks (a scene of several objects, docs/picks.md):
each a rigid body of its own convex pieces, made again at its resting pose before every trial as the world's own
object is (Bullet keeps contact caches on a body), so what the world executed before moves no outcome."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pybullet as pb

from onepiece_dist.core.frames import apply_rotation, quat_from_matrix
from onepiece_dist.sim.world import _write_hulls, matrix_from_pose


@dataclass(frozen=True)
class Neighbour:
    """An object standing beside the picked one: its convex ``pieces`` ((k, 3) each, its mesh frame), ``mass``
    (kg), ``friction`` and ``resting`` (4, 4), its mesh frame's pose in the world."""

    pieces: tuple[np.ndarray, ...]
    mass: float
    friction: float
    resting: np.ndarray


class Beside:
    """A world's neighbours and their bodies (none: every call is a no-op, so a world of one object steps as it
    did). pybullet reads a mesh shape's file again for every body made from it: each neighbour's file stays while
    it is set."""

    def __init__(self) -> None:
        self.neighbours: tuple[Neighbour, ...] = ()
        self.bodies: list[int] = []
        self._files: list[str] = []
        self._shapes: list[int] = []
        self._centroids: list[np.ndarray] = []

    def set(self, client: int, neighbours: tuple[Neighbour, ...]) -> None:
        """Stand ``neighbours`` on the table at their resting poses (the previous ones removed)."""
        self.clear(client)
        self.neighbours = tuple(neighbours)
        for n in self.neighbours:
            centroid = np.vstack(n.pieces).mean(axis=0)
            self._files.append(_write_hulls([p - centroid for p in n.pieces]))
            self._shapes.append(pb.createCollisionShape(pb.GEOM_MESH, fileName=self._files[-1],
                                                        physicsClientId=client))
            self._centroids.append(centroid)
        self.reset(client)

    def reset(self, client: int) -> int:
        """Every neighbour's body made again at its resting pose, at rest. Returns the bodies made."""
        for body in self.bodies:
            pb.removeBody(body, physicsClientId=client)
        self.bodies = []
        for n, shape, centroid in zip(self.neighbours, self._shapes, self._centroids, strict=True):
            centre = n.resting[:3, 3] + apply_rotation(n.resting[:3, :3], centroid)
            body = pb.createMultiBody(baseMass=n.mass, baseCollisionShapeIndex=shape, basePosition=centre.tolist(),
                                      baseOrientation=quat_from_matrix(n.resting[:3, :3]), useMaximalCoordinates=True,
                                      physicsClientId=client)
            pb.changeDynamics(body, -1, lateralFriction=n.friction, physicsClientId=client)
            self.bodies.append(body)
        return len(self.bodies)

    def poses(self, client: int) -> list[np.ndarray]:
        """(4, 4) each neighbour's mesh-frame pose in the world now."""
        out = []
        for body, centroid in zip(self.bodies, self._centroids, strict=True):
            pose = matrix_from_pose(*pb.getBasePositionAndOrientation(body, physicsClientId=client))
            pose[:3, 3] -= apply_rotation(pose[:3, :3], centroid)
            out.append(pose)
        return out

    def speed(self, client: int) -> float:
        """The largest linear (m/s) or angular (rad/s) speed of any neighbour; 0 without neighbours."""
        speeds = [np.abs(np.concatenate(pb.getBaseVelocity(b, physicsClientId=client))).max() for b in self.bodies]
        return float(max(speeds, default=0.0))

    def clear(self, client: int | None) -> None:
        """Remove every neighbour (``client`` None: the client is gone, only the files are deleted)."""
        if client is not None:
            for body in self.bodies:
                pb.removeBody(body, physicsClientId=client)
        for path in self._files:
            Path(path).unlink(missing_ok=True)
        self.neighbours, self.bodies, self._files, self._shapes, self._centroids = (), [], [], [], []
