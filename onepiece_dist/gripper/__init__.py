"""Grippers: the presets (``presets``) and a gripper read from a URDF's finger links (``urdf``)."""
