"""The dataset layout as data: the contract for outside readers, exported to schemas/dataset_layout.json."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

from onepiece_dist.store.format import GRASP_ARRAYS

LABELLED_ONLY = ("object", "code_index", "exact_index")  # per-object bookkeeping, not on the one object's grasps
SKIPPED = {"grasps": ("patch", "row", "round"), "assembled/grasps": (*LABELLED_ONLY, "row", "round"),
           "labelled/grasps": ("patch", "code_index", "exact_index")}


def _grasp_entries(group: str, rows: str) -> tuple[tuple[str, str, str, str], ...]:
    """The per-grasp arrays of ``group`` (``rows`` of them) from the one grasp-array schema (store/format.py)."""
    entries = []
    for name, dtype, row_shape, meaning in GRASP_ARRAYS:
        if name in SKIPPED[group]:
            continue
        inner = [part for part in row_shape.strip("()").replace(" ", "").split(",") if part]
        entries.append((f"{group}/{name}", dtype, f"({', '.join([rows, *inner])}{',' if not inner else ''})", meaning))
    return tuple(entries)


# (path, dtype, shape, meaning). N grasps, U unique codes, n objects, B code bytes.
ARRAYS: tuple[tuple[str, str, str, str], ...] = (
    ("objects/id", "uint8", "(n, 16)", "content id of each accepted object (blake2b-128 of scaled geometry)"),
    ("objects/name", "uint8", "(n, 64)", "object name, UTF-8, zero-padded"),
    ("objects/grasp_start", "int64", "(n,)", "first row of the object's grasps"),
    ("objects/grasp_count", "int64", "(n,)", "number of the object's grasps"),
    *_grasp_entries("grasps", "N"),
    ("unique/code", "uint8", "(U, B)", "distinct codes in byte order (cluster representatives if radius > 0)"),
    ("unique/count", "int64", "(U,)", "grasps per distinct code (per cluster when similar_radius > 0)"),
    ("unique/representative", "int64", "(U,)", "row in grasps/ of each code's representative: its first grasp "
     "(a cluster's: the first grasp of its representative code)"),
    ("unique/points", "float16", "(U, P, 3)", "the representative's points (as grasps/points), kept when grasps/points "
     "is left out (a job that labels on the one object) or not"),
    ("exact/code", "uint8", "(E, B)", "with similar_radius > 0: the exact distinct codes"),
    ("exact/count", "int64", "(E,)", "with similar_radius > 0: grasps per exact code"),
    ("exact/cluster", "int64", "(E,)", "with similar_radius > 0: row in unique/ of each exact code's cluster"),
    ("views/camera", "float32", "(K, 4, 4)", "depth camera poses, camera-to-object, OpenGL axes (looks along -z)"),
    ("views/camera_object", "int32", "(K,)", "row in objects/ of each camera"),
    ("views/points", "float32", "(Q, 3)", "back-projected depth pixels in their object's frame"),
    ("views/point_camera", "int32", "(Q,)", "row in views/camera of each point"),
    ("assembled/placement", "float32", "(U, 4, 4)", "gripper pose on the one object that sees unique code k"),
    ("assembled/plane", "int8", "(U,)", "chosen projection plane: 0 uv, 1 ut, 2 vt"),
    ("assembled/areas", "int64", "(U, 3)", "projected areas on uv, ut, vt"),
    ("assembled/features", "int64", "(U, 3)", "L-shaped 2x2 edge features on uv, ut, vt"),
    ("assembled/scores", "float32", "(U, 3)", "area ratio x feature count per plane"),
    ("assembled/vertices", "float32", "(V, 3)", "mesh of the one object"),
    ("assembled/faces", "int32", "(F, 3)", "mesh triangles"),
    ("assembled/face_group", "int8", "(F,)", "plane class of the patch a triangle belongs to, 3 = core"),
    ("assembled/core_half", "float64", "(3,)", "half extents of the core box the patches are laid on (m)"),
    ("assembled/code_count", "int64", "(U,)", "extracted grasps each patch stands for (unique/count, kept here)"),
    ("assembled/representative", "int64", "(U,)", "row in grasps/ of the grasp each patch was cut from"),
    ("assembled/patch_piece_count", "int64", "(U,)", "convex pieces of each patch (in patch order)"),
    ("assembled/piece_vertex_count", "int64", "(K,)", "points of each convex piece (in piece order)"),
    ("assembled/piece_vertices", "float32", "(W, 3)", "points of the pieces, patch (gripper) frame; each piece "
     "is their convex hull"),
    ("assembled/source_point_count", "int64", "(S,)", "surface points of each source object a patch is cut from"),
    ("assembled/source_points", "uint16", "(Q, 3)", "their dense surface points, object frame, once per object, in "
     "steps of source_box: a patch's points are those inside its patch box at its source pose"),
    ("assembled/source_box", "float64", "(S, 2, 3)", "each source's lower corner and step (m): a point is lower + "
     "steps * step"),
    ("assembled/source_object", "int64", "(U,)", "which source (row of source_point_count) each patch is cut from"),
    ("assembled/source_pose", "float32", "(U, 4, 4)", "the representative's settled pose on its source object"),
    ("assembled/source_volume", "float64", "(U,)", "volume of each patch's source object (m^3): its mass rule"),
    *_grasp_entries("assembled/grasps", "L"),
    *_grasp_entries("labelled/grasps", "L2"),  # a budget's or adaptive rounds' labelled candidates
    ("adaptive/scores", "float32", "(R, N)", "adaptive labelling: each round's network's success probability of "
     "every candidate of grasps/ (what chose the next round's batch)"),
    ("adaptive/validation_objects", "int64", "(V,)", "adaptive labelling: rows in objects/ held out from the rounds "
     "(their labelled grasps measure each round's validation AP)"),
    ("train/train_loss", "float32", "(T,)", "training loss of each epoch (T epochs run)"),
    ("train/val_loss", "float32", "(T,)", "validation loss of each epoch"),
    ("train/val_accuracy", "float32", "(T,)", "validation accuracy of each epoch"),
    ("train/val_ap", "float32", "(T,)", "validation average precision of each epoch"),
    ("train/val_positives", "float32", "(T,)", "share of positive labels in the validation split"),
)


class ArraySpec(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")
    path: str
    dtype: str
    shape: str
    meaning: str


class DatasetAttributes(BaseModel):
    """Root attributes of a dataset (Zarr v3 group, format v2). Arrays are listed under ``x-arrays``."""

    model_config = ConfigDict(extra="allow", json_schema_extra={
        "x-arrays": [ArraySpec(path=p, dtype=d, shape=s, meaning=m).model_dump() for p, d, s, m in ARRAYS]})
    onepiece_format: int = Field(2, description="Format version of this layout (2: the one object's points are "
                                 "derived from its sources, not stored).")
    complete: bool = Field(description="Written true last by the committer; readers refuse false.")
    job_spec: dict = Field(description="The JobSpec that made the dataset.")
    gripper: dict = Field(description="The gripper (job_spec.gripper): its frame and closing region.")
    voxel: dict = Field(description="The voxel grid (job_spec.voxel).")
    grid_shape: list[int] = Field(description="(a, b, c) voxels along (u, v, t).")
    code_bytes: int = Field(description="B = ceil(a*b*c/8).")
    code_bit_order: str = Field(description="How a code's bits pack: C order over (u, v, t), numpy packbits "
                                            "bitorder 'big'.")
    pose_convention: str = Field(description="What grasps/pose holds: gripper-to-object 4x4, columns u, v, t.")
    provenance: dict = Field(description="package_version, seed, result_key.")
    rejected: list[dict] = Field(description="Objects rejected with a reason: {name, reason}.")
    ingest: list[dict] = Field(default_factory=list, description="Objects accepted with repairs or few grasps: "
                               "{name, repairs (what loading repaired: UV seams welded, faces flipped, holes "
                               "capped for the mass), shortfall (why fewer than half the grasps asked were kept)}.")
    stats: dict = Field(description="Extraction counts: objects total, ok and rejected, grasps, empty crops, "
                                    "candidates tried, collisions, settled codes that differ from the nominal.")
    assembly: dict | None = Field(None, description="The assemble stage's report (AssemblyReport in "
                                                    "schemas/job_status.schema.json), once assembled.")
    assembly_labels: dict | None = Field(None, description="The label stage's report (LabelReport, with label "
                                                           "transfer), once labelled on the one object.")
    budget_labels: dict | None = Field(None, description="A budget's label stage (labelled/grasps): labelled "
                                       "grasps, label trials, success rate, what was asked, whether it was every "
                                       "candidate, the label stage's core-seconds.")
    adaptive: dict | None = Field(None, description="Adaptive labelling's rounds (AdaptiveReport): each round's "
                                  "labels, validation AP and network, and why the rounds stopped.")
    training: dict | None = Field(None, description="The train stage's report (TrainingReport), once trained.")
    evaluation: dict | None = Field(None, description="The evaluate stage's report (EvaluationReport): the trained "
                                    "network on held-out objects, once evaluated.")
