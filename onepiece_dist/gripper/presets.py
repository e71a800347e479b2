"""Grippers people own, as GripperSpec fields (plain values; ``gripper: panda`` in a job spec picks one).

Sources (the peers' public files and the vendors' public figures, where they could be read):
- Franka Panda hand: 8 cm stroke (two 0-4 cm prismatic joints, pybullet_data franka_panda/panda.urdf); fingers
  from 6.6 to 11.2 cm along the approach (acronym_tools' gripper marker): 4.6 cm long; pad face 17.5 mm wide
  (franka_ros' grasping pads); 70 N continuous grip force (as 6-DOF GraspNet used).
- Robotiq 2F-85: 85 mm stroke, 20-235 N (Robotiq's SDK device profile); pad 22 x 37.5 x 8 mm (mujoco_menagerie
  robotiq_2f85); 100 N here, a mid setting.
- Robotiq 2F-140: 140 mm stroke, 10-125 N (vendor figure, not checked here); pad size not published where we
  looked: the 2F-85's pad height and a 5 cm finger are assumed.
The closing region (the crop) is the largest box of whole 1 cm voxels between the fingers.
"""

from __future__ import annotations

from typing import Any

PRESETS: dict[str, dict[str, float | str]] = {
    "panda": {"name": "franka_panda", "max_opening": 0.08, "finger_length": 0.046, "finger_thickness": 0.0105,
              "finger_height": 0.0175, "palm_depth": 0.0584, "palm_height": 0.06, "closing_depth": 0.04,
              "closing_width": 0.08, "closing_height": 0.02, "closing_force": 70.0, "finger_mass": 0.015},
    "robotiq_2f85": {"name": "robotiq_2f_85", "max_opening": 0.085, "finger_length": 0.0475,
                     "finger_thickness": 0.008, "finger_height": 0.022, "palm_depth": 0.06, "palm_height": 0.075,
                     "closing_depth": 0.04, "closing_width": 0.08, "closing_height": 0.02, "closing_force": 100.0,
                     "finger_mass": 0.03},
    "robotiq_2f140": {"name": "robotiq_2f_140", "max_opening": 0.14, "finger_length": 0.05,
                      "finger_thickness": 0.008, "finger_height": 0.022, "palm_depth": 0.06, "palm_height": 0.075,
                      "closing_depth": 0.05, "closing_width": 0.14, "closing_height": 0.02, "closing_force": 60.0,
                      "finger_mass": 0.04},
}


def gripper_fields(value: Any) -> Any:
    """A gripper given as a preset's name, or as a mapping with ``preset: NAME`` or ``urdf: PATH`` (its finger
    links, gripper.urdf) and overrides, as its fields."""
    if isinstance(value, dict) and "urdf" in value:
        from onepiece_dist.gripper.urdf import gripper_from_urdf

        return {**gripper_from_urdf(value["urdf"]), **{k: v for k, v in value.items() if k != "urdf"}}
    name = value if isinstance(value, str) else value.get("preset") if isinstance(value, dict) else None
    if name is None:
        return value
    if name not in PRESETS:
        raise ValueError(f"unknown gripper preset {name!r}: expected one of {', '.join(sorted(PRESETS))}")
    overrides = {k: v for k, v in value.items() if k != "preset"} if isinstance(value, dict) else {}
    return {**PRESETS[name], **overrides}
