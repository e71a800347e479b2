"""The dataset format in one place: its version, the check every reader makes, and the grasp-array schema
that every writer (extraction parts, the commit, the label stage) and every reader uses.

Imports numpy only, so outside readers can use it without the rest of the package.
"""

from __future__ import annotations

import numpy as np

FORMAT_VERSION = 2
FORMAT_CHANGES = {1: "format 1 stored the one object's dense point cloud twice (assembled/points, "
                     "assembled/patch_points); format 2 keeps each source object's surface once and derives them"}

# Per-grasp arrays of ``grasps/`` and ``assembled/grasps/``: (name, dtype, row shape, meaning). N rows; row shape
# symbols: B code bytes, P points per grasp. Optional arrays are present only when the job produces them.
GRASP_ARRAYS: tuple[tuple[str, str, str, str], ...] = (
    ("object", "int32", "()", "row in objects/ of each grasp"),
    ("pose", "float32", "(4, 4)", "gripper pose in the object frame whose crop gives the code"),
    ("candidate_pose", "float32", "(4, 4)", "nominal (static) candidate pose"),
    ("width", "float32", "()", "finger opening after closing (m)"),
    ("shift", "float32", "()", "object displacement during closing (m)"),
    ("candidate_code", "uint8", "(B,)", "code at the nominal candidate pose"),
    ("points", "float16", "(P, 3)", "gripper-frame points in the closing region, resampled to P, at the settled "
     "pose (at the candidate pose with views.sampling: view) (in grasps/, every grasp's only without the label stage "
     "or with keep_all_points: else unique/points)"),
    ("success", "uint8", "()", "label protocol outcome (only when labelled)"),
    ("quality", "float32", "()", "success fraction over label trials (only when labelled)"),
    ("slip", "float32", "()", "object motion in the gripper frame while lifting and shaking (m)"),
    ("code", "uint8", "(B,)", "packed voxel code of the crop, C order over (u, v, t), bitorder big"),
    ("code_index", "int64", "()", "row in unique/ of each grasp's code (or its cluster)"),
    ("exact_index", "int64", "()", "with similar_radius > 0: row in exact/ of each grasp's code"),
    ("patch", "int32", "()", "assembled/grasps only: the patch (row in unique/) a labelled grasp belongs to"),
    ("row", "int64", "()", "labelled/grasps only: the row in grasps/ of a budget's labelled grasp"),
    ("round", "int32", "()", "labelled/grasps of adaptive labelling only: the round that labelled the grasp (0: "
     "the first, with the validation set)"),
    ("fc_mu", "float32", "()", "smallest friction of closure.levels at which the grasp is in force closure, +inf "
     "for none (only with closure.enabled)"),
    ("fc_epsilon", "float32", "()", "Ferrari-Canny L1 epsilon at closure.epsilon_mu, 0 without closure (only with "
     "closure.enabled)"),
    ("physics_success", "uint8", "()", "the physics trials' outcome when closure.label makes success another "
     "label (force closure, or both)"),
    ("fc_contacts", "int8", "()", "pad contacts: 0 two, 1 a pad met nothing, 2 one point (only with "
     "closure.enabled)"),
    ("source_row", "int64", "()", "grasps brought in (onepiece label --grasps) only: the row of the grasp file "
     "each grasp came from; the file's rows not here did not hold"),
)
GRASP_DTYPES: dict[str, np.dtype] = {name: np.dtype(dtype) for name, dtype, _, _ in GRASP_ARRAYS}
# What every extraction part holds, with or without physics and labels.
CORE_GRASP_ARRAYS = ("pose", "candidate_pose", "width", "code", "candidate_code")


def grasp_arrays(arrays: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """``arrays`` cast to the schema's dtype of each name. Unknown names are a bug and raise KeyError."""
    unknown = sorted(set(arrays) - set(GRASP_DTYPES))
    if unknown:
        raise KeyError(f"not grasp arrays of format {FORMAT_VERSION}: {unknown}")
    return {name: np.asarray(value, dtype=GRASP_DTYPES[name]) for name, value in arrays.items()}


def grasp_row_shape(name: str, code_bytes: int, points: int) -> tuple[int, ...]:
    """The row shape of grasp array ``name`` for B = ``code_bytes`` and P = ``points``."""
    text = next(shape for n, _, shape, _ in GRASP_ARRAYS if n == name)
    symbols = {"B": code_bytes, "P": points}
    return tuple(symbols[s] if s in symbols else int(s) for s in text.strip("()").replace(" ", "").split(",") if s)


def format_problem(attrs: dict) -> str | None:
    """Why root attributes ``attrs`` are not those of a complete dataset of this format, or None when they are."""
    found = attrs.get("onepiece_format")
    if found != FORMAT_VERSION:
        why = f" ({FORMAT_CHANGES[found]}): run its job again to write format {FORMAT_VERSION} (its extraction " \
              "parts are reused)" if found in FORMAT_CHANGES else ""
        return f"onepiece_format={found!r}, this reader knows {FORMAT_VERSION}{why}"
    if not attrs.get("complete"):
        return "dataset is incomplete (its job has not committed it)"
    return None
