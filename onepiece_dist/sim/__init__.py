"""pybullet grasp trials. Only validated, sanitized meshes (from ``objects``) ever reach pybullet."""
