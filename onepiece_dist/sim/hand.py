"""Gripper drawings for pictures (never for physics): the Franka Panda hand's meshes shipped in ``pybullet_data``,
or boxes of the :class:`GripperSpec` model that the trials simulate.

Panda hand frame (``franka_panda/panda.urdf``): z = approach, fingers slide along +-y, finger joints at
z = 0.0584 m, the point between the finger pads (``panda_grasptarget``) at z = 0.105 m. The hand is drawn so that
this point lies at the centre of the model's closing region, with its y along the closing axis v: the gripper
frame's u = hand z, v = hand y, t = u x v = -hand x (docs/gripper_frame.md).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from onepiece_dist.core.frames import quat_from_matrix
from onepiece_dist.specs.job import GripperSpec

PANDA_FINGER_JOINTS = 0.0584  # m along the hand's z
PANDA_GRASP_TARGET = 0.105  # m along the hand's z
HAND_AXES_IN_GRIPPER = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])  # columns: hand x, y, z
HANDS = ("panda", "model")


def _pose(rotation: np.ndarray, translation) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3], out[:3, 3] = rotation, translation
    return out


def panda_parts(pose: np.ndarray, width: float, gripper: GripperSpec) -> list[tuple[str, np.ndarray]]:
    """Where the Panda's meshes go for a grasp.

    pose : (4, 4) float  gripper pose in the object frame; width : opening between the pads (m)
    returns : [(mesh file name under franka_panda/meshes/visual, (4, 4) mesh pose in the object frame)] for the
              hand and both fingers
    """
    hand_in_gripper = _pose(HAND_AXES_IN_GRIPPER, [gripper.closing_depth / 2 - PANDA_GRASP_TARGET, 0.0, 0.0])
    hand = pose @ hand_in_gripper
    half = float(np.clip(width, 0.0, 0.08)) / 2  # the Panda opens 8 cm at most
    left = hand @ _pose(np.eye(3), [0.0, half, PANDA_FINGER_JOINTS])
    right = hand @ _pose(np.diag([-1.0, -1.0, 1.0]), [0.0, -half, PANDA_FINGER_JOINTS])  # turned about z
    return [("hand.obj", hand), ("finger.obj", left), ("finger.obj", right)]


def model_parts(pose: np.ndarray, width: float, gripper: GripperSpec) -> list[tuple[np.ndarray, np.ndarray]]:
    """Boxes of the simulated gripper for a grasp: [(half extents (3,), (4, 4) box pose in the object frame)]
    for the palm and both fingers, the fingers ``width`` apart."""
    g = gripper
    side = min(width, g.max_opening) / 2 + g.finger_thickness / 2
    palm = (np.array([g.palm_depth / 2, g.max_opening / 2 + g.finger_thickness, g.palm_height / 2]),
            pose @ _pose(np.eye(3), [-g.palm_depth / 2, 0.0, 0.0]))
    finger = np.array([g.finger_length / 2, g.finger_thickness / 2, g.finger_height / 2])
    return [palm] + [(finger, pose @ _pose(np.eye(3), [g.finger_length / 2, s * side, 0.0])) for s in (-1, 1)]


def add_hand(pb, client: int, pose: np.ndarray, width: float, gripper: GripperSpec, hand: str,
             rgba: tuple[float, float, float, float]) -> list[int]:
    """Add visual-only bodies that draw the gripper at ``pose`` to a pybullet ``client`` (``pb`` the module);
    returns their body ids."""
    if hand not in HANDS:
        raise ValueError(f"hand={hand!r}: expected one of {HANDS}")
    if hand == "panda":
        folder = panda_meshes()
        shapes = [(pb.createVisualShape(pb.GEOM_MESH, fileName=str(folder / name), rgbaColor=rgba,
                                        physicsClientId=client), at) for name, at in panda_parts(pose, width, gripper)]
    else:
        shapes = [(pb.createVisualShape(pb.GEOM_BOX, halfExtents=half.tolist(), rgbaColor=rgba,
                                        physicsClientId=client), at) for half, at in model_parts(pose, width, gripper)]
    return [pb.createMultiBody(baseVisualShapeIndex=shape, basePosition=at[:3, 3].tolist(),
                               baseOrientation=quat_from_matrix(at[:3, :3]), physicsClientId=client)
            for shape, at in shapes]


def panda_meshes() -> Path:
    """The folder of the Panda's visual meshes in the installed ``pybullet_data``."""
    import pybullet_data

    folder = Path(pybullet_data.getDataPath()) / "franka_panda" / "meshes" / "visual"
    if not (folder / "hand.obj").is_file():
        raise FileNotFoundError(f"{folder}: no Panda hand mesh in this pybullet_data")
    return folder
