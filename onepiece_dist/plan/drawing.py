"""Planned grasps drawn on their cloud as a PNG a person can look at (matplotlib, the ``plots`` extra)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from onepiece_dist.core.frames import transform_points
from onepiece_dist.specs.job import GripperSpec

MAX_DRAWN_POINTS = 6000


def gripper_outline(pose: np.ndarray, gripper: GripperSpec) -> np.ndarray:
    """(6, 3) a U of the open gripper at ``pose``: stem, palm and both fingers, in the pose's frame, as a polyline
    fingertip, finger base, palm end, (stem via palm centre), palm end, finger base, fingertip."""
    half, length = gripper.max_opening / 2, gripper.finger_length
    local = np.array([[length, -half, 0], [0, -half, 0], [0, 0, 0], [-2 * gripper.palm_depth, 0, 0], [0, 0, 0],
                      [0, half, 0], [length, half, 0]], dtype=np.float64)
    return transform_points(local, pose)


def draw_plan(points: np.ndarray, grasps, gripper: GripperSpec, path: str | Path, viewpoint: np.ndarray | None = None,
              title: str = "", plane_points: np.ndarray | None = None) -> Path:
    """Write a PNG of ``points`` (m, 3) with ``grasps`` (PlannedGrasp, best first) drawn as grippers: the best in
    green, the others in shades of orange by score. Seen from ``viewpoint`` when given."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig = plt.figure(figsize=(6, 6), dpi=100)
    ax = fig.add_subplot(projection="3d")
    step = max(1, len(points) // MAX_DRAWN_POINTS)
    shown = points[::step]
    ax.scatter(shown[:, 0], shown[:, 1], shown[:, 2], s=1, c=shown[:, 2], cmap="Greys", alpha=0.6)
    if plane_points is not None and len(plane_points):
        table = plane_points[:: max(1, len(plane_points) // 2000)]
        ax.scatter(table[:, 0], table[:, 1], table[:, 2], s=1, c="#c8b48c", alpha=0.3)
    for grasp in reversed(grasps):
        line = gripper_outline(grasp.pose, gripper)
        best = grasp.rank == 1
        colour = "#1a9850" if best else plt.cm.Oranges(0.35 + 0.6 * float(grasp.score))
        ax.plot(line[:, 0], line[:, 1], line[:, 2], color=colour, linewidth=3.0 if best else 1.2)
    _frame(ax, points, viewpoint)
    ax.set_title(title or f"{len(grasps)} planned grasps (best in green)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def _frame(ax, points: np.ndarray, viewpoint: np.ndarray | None) -> None:
    centre = (points.max(axis=0) + points.min(axis=0)) / 2
    radius = max(float(np.max(points.max(axis=0) - points.min(axis=0))) / 2, 0.02) * 1.2
    for setter, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre, strict=True):
        setter(c - radius, c + radius)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel("x (m)", fontsize=7)
    ax.set_ylabel("y (m)", fontsize=7)
    ax.set_zlabel("z (m)", fontsize=7)
    ax.tick_params(labelsize=6)
    if viewpoint is not None:
        d = np.asarray(viewpoint) - centre
        ax.view_init(elev=float(np.degrees(np.arctan2(d[2], np.hypot(d[0], d[1])))),
                     azim=float(np.degrees(np.arctan2(d[1], d[0]))))


def write_plan(plan, observation, gripper: GripperSpec, folder: str | Path, name: str = "grasps",
               extra: dict | None = None) -> tuple[Path, Path | None]:
    """``folder/NAME.json`` (the plan, the gripper and ``extra``) and ``folder/NAME.png`` (the drawing; None where
    matplotlib is not installed). Returns both paths."""
    import json

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    document = {**plan.to_json(), "gripper": gripper.model_dump(mode="json"), **(extra or {})}
    json_path = folder / f"{name}.json"
    json_path.write_text(json.dumps(document, indent=1) + "\n")
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return json_path, None
    plane = plan.plane
    objects = observation.points if plane is None else observation.points[~plane.inliers]
    table = None if plane is None else observation.points[plane.inliers]
    png = draw_plan(objects, plan.grasps, gripper, folder / f"{name}.png", observation.viewpoint,
                    f"{observation.source}: {len(plan.grasps)} grasps, best {plan.grasps[0].score:.2f}"
                    if plan.grasps else f"{observation.source}: no grasp found", table)
    return json_path, png
