"""Geometry on an observed point cloud: grasp candidates and the support plane (``grasps``), whether a plane is
the table (``support_check``), and the top-down baseline grasp (``top_down``)."""
