"""What stages hand each other: a worker's per-object result and the commit's summary. Small, frozen, and cheap
to send through Ray (no arrays: those stay in the store)."""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields


@dataclass(frozen=True)
class ObjectPartMeta:
    """What an object's extraction part records of it (the part's attributes, written by the extract stage): its
    counts, the physics it was simulated with and what making it cost. Parts written before a field existed read
    as its default."""

    content_id: str
    grasps: int
    empty_crops: int
    candidates_tried: int
    collisions: int
    name: str = ""
    trials: int = 0
    settled_code_differs: int = 0
    dropped_start_collision: int = 0
    dropped_no_contact: int = 0
    dropped_invalid: int = 0
    volume: float = 0.0
    density: float | None = None  # a folder manifest's, or the job's sim.density when the part was made
    friction: float = 1.0
    made_seconds: float | None = None

    @classmethod
    def from_attrs(cls, attrs: dict) -> ObjectPartMeta:
        known = {field.name for field in fields(cls)}
        return cls(**{name: value for name, value in attrs.items() if name in known})


@dataclass(frozen=True)
class ObjectResult:
    """Summary of one object's extraction; ``status`` is 'ok' or 'rejected' (with ``reason``)."""

    index: int
    name: str
    status: str
    reason: str = ""
    content_id: str = ""
    part_key: str = ""
    grasps: int = 0
    empty_crops: int = 0
    candidates_tried: int = 0
    collisions: int = 0
    settled_code_differs: int = 0
    reused: bool = False
    seconds: float = 0.0
    node: str = ""
    made_seconds: float = 0.0  # what the part cost to make when first made (a reused part: its original time)
    repairs: str = ""  # what loading repaired ("; "-joined), e.g. faces wound inwards, flipped
    shortfall: str = ""  # why fewer than half the grasps asked for were kept ('' when enough were)

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class CommitSummary:
    """The committed dataset's counts: grasps, unique codes (clusters with a similar radius) and exact codes."""

    grasps: int
    unique_codes: int
    exact_unique_codes: int


def part_key(content_id: str, result_key: str) -> str:
    """The part of an object: its content id and the result key of the spec that extracted it (same physics,
    same part). A dataset records its result key in ``provenance``, so later stages find its parts."""
    return f"{content_id}-{result_key}"


@dataclass(frozen=True)
class LabelTask:
    """A shard of the label stage: patches [start, stop) of the one object at ``dataset``, whose patches and
    label-relevant spec hash to ``label_key``; its labelled grasps go to the part ``part_key`` (so a re-run, or a
    resumed job, finds the shard done). With ``rows``: a budget shard, those rows of grasps/ (one object's) labelled
    on their own object, [start, stop) their positions among the job's chosen rows (job/stages/label_budget.py)."""

    start: int
    stop: int
    dataset: str
    label_key: str
    rows: tuple[int, ...] | None = None
    round: int | None = None  # adaptive labelling: the round whose batch this shard belongs to

    @property
    def part_key(self) -> str:
        return f"label-{self.label_key}-{self.start:06d}"


@dataclass(frozen=True)
class PatchTask:
    """A shard of the assemble stage's patch cutting: patches [start, stop), in source-object order
    (job/stages/patch_shards.py), of the committed dataset at ``dataset``; its part is keyed by ``patch_key``."""

    start: int
    stop: int
    dataset: str
    patch_key: str

    @property
    def part_key(self) -> str:
        return f"patch-{self.patch_key}-{self.start:06d}"


@dataclass(frozen=True)
class ShardResult:
    """A labelled (or patch) shard: 'ok' with its part and grasp (patch) count, or 'rejected' (its worker kept
    dying)."""

    index: int
    status: str
    part_key: str = ""
    grasps: int = 0
    reason: str = ""
    reused: bool = False
    seconds: float = 0.0
    node: str = ""
    made_seconds: float = 0.0  # what the part cost to make when first made (a reused part: its original time)
