"""The Franka Panda hand's grasp frame (ACRONYM, GraspGen), mapped to ours (docs/dataset_format.md, Other formats).

Ours: gripper-to-object 4x4, columns u (approach, palm to fingertips), v (closing), t = u x v; origin at the palm
centre; the closing region 0 <= u < closing_depth, |v| < closing_width / 2, |t| < closing_height / 2.

**Franka Panda hand (ACRONYM, GraspGen).** acronym_tools' ``create_gripper_marker`` draws the hand: origin at the
hand's base, approach along +z, the fingers at x = +-0.041 from z = 0.066 (their base) to z = 0.11217 (their tips),
so the fingers close along x and y = z x x. Its axes are ours renamed: x = v, y = t, z = u. Its origin lies on our
approach axis where the fingertips coincide: our tips at u = finger_length are the Panda's at z = 0.11217, so the
region our fingers held (0 <= u < closing_depth) lies between the Panda's fingers too.

PointNetGPD's crop frame: learn.dataset.pointnetgpd_crop.
"""

from __future__ import annotations

import numpy as np

from onepiece_dist.core.frames import compose_poses, invert_poses

PANDA_FINGER_X = 0.041  # m, each finger's offset along the Panda's x (closing) axis, fully open
PANDA_FINGER_BASE_Z = 0.066  # m, where the fingers start along the Panda's z (approach) axis
PANDA_FINGERTIP_Z = 0.11217  # m, the fingertips
PANDA_CLOSING_CENTRE = np.array([0.0, 0.0, (PANDA_FINGER_BASE_Z + PANDA_FINGERTIP_Z) / 2])  # Panda frame


def panda_in_gripper(finger_length: float) -> np.ndarray:
    """(4, 4) the Panda hand's frame expressed in our gripper frame: x = v, y = t, z = u, origin on the approach
    axis so that the fingertips coincide."""
    out = np.zeros((4, 4))
    out[:3, 0], out[:3, 1], out[:3, 2] = [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]
    out[:3, 3] = [finger_length - PANDA_FINGERTIP_Z, 0.0, 0.0]
    out[3, 3] = 1.0
    return out


def to_panda(poses: np.ndarray, finger_length: float) -> np.ndarray:
    """Our gripper-to-object poses (..., 4, 4) as Panda hand-to-object transforms (ACRONYM's, GraspGen's)."""
    return compose_poses(poses, panda_in_gripper(finger_length))


def from_panda(transforms: np.ndarray, finger_length: float) -> np.ndarray:
    """Panda hand-to-object transforms (..., 4, 4) as our gripper-to-object poses (the inverse of to_panda)."""
    return compose_poses(transforms, invert_poses(panda_in_gripper(finger_length)))

