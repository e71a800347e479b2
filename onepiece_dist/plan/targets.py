"""The objects a plan saw and the one it is asked to pick (docs/planning.md): a robot told to pick one object of
several names a point on it (PlanSpec.target, `onepiece grasp --target x,y,z`), and the planner keeps only the
grasps that close on the object told apart nearest that point (core.cloud.objects). Each planned grasp says which
object it closes on; the plan lists the objects with their centres."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from onepiece_dist.core.cloud.objects import closed_on_each
from onepiece_dist.core.frames import transform_points
from onepiece_dist.core.grasp_context import object_centre
from onepiece_dist.errors import CloudRejected
from onepiece_dist.specs.job import GripperSpec

TARGET_REACH = 0.05  # m: a target farther than this from every object's points names none of them


@dataclass(frozen=True)
class SeenObject:
    """One object told apart in the view: ``index`` (0 the one with the most points), ``centre`` (3,) the middle
    of its points' bounding box, and how many ``points`` it holds."""

    index: int
    centre: np.ndarray
    points: int

    def moved(self, pose: np.ndarray) -> SeenObject:
        """The same object in another frame: ``pose`` (4, 4) maps the planning frame into it."""
        return SeenObject(self.index, transform_points(self.centre[None], pose)[0], self.points)

    def to_json(self) -> dict:
        return {"index": self.index, "centre": np.round(self.centre, 9).tolist(), "points": self.points}


def seen_objects(apart: tuple[np.ndarray, ...] | None) -> tuple[SeenObject, ...]:
    """Each object told apart (largest first), as the plan lists them."""
    return tuple(SeenObject(k, object_centre(points), len(points)) for k, points in enumerate(apart or ()))


def grasped_objects(apart: tuple[np.ndarray, ...] | None, poses: np.ndarray, gripper: GripperSpec) -> np.ndarray:
    """(n,) int: the object of ``apart`` each of ``poses`` closes on (closed_on); 0 for all where one or none."""
    return closed_on_each(list(apart or ()), poses, gripper.closing_depth, gripper.closing_width,
                          gripper.closing_height)


def target_object(apart: tuple[np.ndarray, ...] | None, target: np.ndarray, source: str) -> int:
    """The object of ``apart`` whose points come nearest ``target`` (3,); CloudRejected, naming the objects seen,
    where none comes within TARGET_REACH."""
    objects = list(apart or ())
    gaps = [float(np.sqrt(np.min(np.sum((points - target) ** 2, axis=1)))) for points in objects if len(points)]
    if not gaps or min(gaps) > TARGET_REACH:
        seen = "; ".join(f"object {o.index} at ({', '.join(f'{v:+.3f}' for v in o.centre)}), {o.points} points"
                         for o in seen_objects(apart)) or "none"
        nearest = f"{min(gaps):.3f} m" if gaps else "no object"
        raise CloudRejected(f"{source}: no object within {TARGET_REACH} m of the target "
                            f"({', '.join(f'{v:+.3f}' for v in target)}): the nearest is {nearest} away. Objects "
                            f"seen: {seen}. Give a point on the object to pick, in the frame of the plan.")
    return int(np.argmin(gaps))
