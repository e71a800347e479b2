"""How often our label agrees with a grasp file's own (``onepiece label --grasps``), in both directions.

The job labels every grasp of the file by our protocol; a grasp that did not hold at all (its fingers started in
the object, closed on nothing, or sent it flying) is not in the dataset and counts as our "fail". The table is
the file's label against ours: both held, ours only, theirs only, neither; with the agreement, Cohen's kappa
(agreement beyond what the two positive rates give by chance) and the two conditional rates: of their successes,
how many hold for us; of ours, how many they call a success.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from onepiece_dist.errors import SourceError
from onepiece_dist.objects.foreign import preset_for, read_foreign_grasps
from onepiece_dist.objects.sources import ObjectRef
from onepiece_dist.specs.job import JobSpec
from onepiece_dist.store import DatasetReader


@dataclass(frozen=True)
class Agreement:
    grasps: int
    both: int  # their success and ours
    ours_only: int
    theirs_only: int
    neither: int
    agreement: float  # (both + neither) / grasps
    kappa: float  # Cohen's kappa; 0 when either label is constant
    their_positive_rate: float
    our_positive_rate: float
    ours_given_theirs: float  # P(ours holds | theirs holds); nan without their successes
    theirs_given_ours: float  # P(theirs holds | ours holds); nan without ours


def agreement(theirs: np.ndarray, ours: np.ndarray) -> Agreement:
    """The confusion table of two (n,) bool labels of the same grasps."""
    theirs, ours = np.asarray(theirs, dtype=bool), np.asarray(ours, dtype=bool)
    n = len(theirs)
    both, neither = int(np.sum(theirs & ours)), int(np.sum(~theirs & ~ours))
    p_t, p_o = float(theirs.mean()) if n else 0.0, float(ours.mean()) if n else 0.0
    observed = (both + neither) / n if n else float("nan")
    chance = p_t * p_o + (1 - p_t) * (1 - p_o)
    kappa = (observed - chance) / (1 - chance) if n and chance < 1 else 0.0
    return Agreement(n, both, int(np.sum(ours & ~theirs)), int(np.sum(theirs & ~ours)), neither, observed, kappa,
                     p_t, p_o, both / theirs.sum() if theirs.any() else float("nan"),
                     both / ours.sum() if ours.any() else float("nan"))


@dataclass(frozen=True)
class FileAgreement:
    name: str
    file: str
    format: str
    gripper: str
    table: Agreement


@dataclass(frozen=True)
class RelabelReport:
    dataset: str
    protocol: str
    files: list[FileAgreement]
    overall: Agreement

    def to_json(self) -> str:
        return json.dumps(asdict(self), indent=1, allow_nan=True) + "\n"


def relabel_report(dataset: str | Path, refs: list[ObjectRef]) -> RelabelReport:
    """Each grasp file's labels against the dataset's (objects matched by name; a file whose object was rejected
    counts every grasp as our fail)."""
    reader = DatasetReader(dataset)
    names = reader.object_names
    start, count = reader["objects/grasp_start"], reader["objects/grasp_count"]
    success, rows = reader["grasps/success"].astype(bool), reader["grasps/source_row"]
    files, theirs_all, ours_all = [], [], []
    for ref in (r for r in refs if r.grasps):
        found = read_foreign_grasps(ref.grasps)
        ours = np.zeros(len(found.held), dtype=bool)
        if ref.name in names:
            k = names.index(ref.name)
            span = slice(int(start[k]), int(start[k] + count[k]))
            ours[rows[span]] = success[span]
        files.append(FileAgreement(ref.name, str(found.path), found.format, found.gripper,
                                   agreement(found.held, ours)))
        theirs_all.append(found.held)
        ours_all.append(ours)
    sim = reader.attrs["job_spec"]["sim"]
    protocol = (f"{sim['label_trials']} label trials per grasp, {sim['success']}; gripper "
                f"{reader.attrs['gripper']['name']}")
    overall = agreement(np.concatenate(theirs_all), np.concatenate(ours_all))
    return RelabelReport(str(dataset), protocol, files, overall)


LABEL_PROTOCOL = {"label": True, "label_trials": 4, "success": "every_trial"}  # as evaluate's: every trial holds


def relabel_spec(files: list[str | Path], out: str | Path, gripper: str | None = None,
                 base: JobSpec | None = None) -> JobSpec:
    """The job that labels every grasp of ``files`` by our protocol (``base``'s settings, default JobSpec, with
    sim.label on; 4 trials that must all hold where ``base`` sets no other) on their meshes, with ``gripper``
    (a preset's name) or the one the files name. Raises SourceError naming a file that cannot be read."""
    found = [read_foreign_grasps(f) for f in files]
    if not found:
        raise SourceError("--grasps: give at least one ACRONYM .h5 or GraspGen .json file")
    plus = [str(f.path) for f in found if "+" in str(f.path)]
    if plus:
        raise SourceError(f"--grasps {plus[0]}: a path with '+' cannot be named in an objects source; rename it")
    presets = {preset_for(f.gripper, f.path) for f in found} if gripper is None else {gripper}
    if len(presets) > 1:
        raise SourceError(f"--grasps: the files name grippers {sorted(presets)}; label one gripper's at a time, "
                          "or choose one with --gripper")
    base = base or JobSpec()
    chosen = base.sim.model_fields_set if "sim" in base.model_fields_set else set()
    sim = {**base.sim.model_dump(), **{k: v for k, v in LABEL_PROTOCOL.items() if k not in chosen}}
    preset = presets.pop()
    return JobSpec.model_validate({
        **base.model_dump(exclude={"gripper", "sim", "objects", "output", "stages", "grasps_per_object"}),
        "objects": "+".join(f"grasps:{f.path}" for f in found), "output": str(out),
        "gripper": preset or base.gripper.model_dump(),
        "stages": ("ingest", "extract"), "sim": {**sim, "label": True},
        "grasps_per_object": max(len(f.held) for f in found)})
