"""Geometry on an observed point cloud: grasp candidates and the support plane (``grasps``), whether a plane is
the table (``support_check``), and the top-down baseline grasp (``top_down``)."""


def import_planning_libraries() -> None:
    """Import now the scipy modules planning on a cloud uses (the normals' k-d tree, the objects' connected
    groups, the check's hull), each imported where used: in a new process they cost about a third of a second,
    which its first plan would otherwise spend (plan.scorer.GraspScorer calls this as it loads a network)."""
    import scipy.sparse.csgraph  # noqa: F401
    import scipy.spatial  # noqa: F401
