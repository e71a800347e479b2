"""Object sources: a built-in set, a folder or a glob, resolved to a sorted list of :class:`ObjectRef`.

Grammar: ``pybullet:named``, ``pybullet:random_urdfs[START:STOP]``, ``primitives`` or ``primitives[START:STOP]``,
``shapes:groceries[START:STOP]`` or ``shapes:vessels[START:STOP]`` (seeded household-sized shapes: objects.shapes),
a folder path, or a glob (``meshes/**/*.obj``). Several sources may be joined with ``+``.
"""

from __future__ import annotations

import glob
import os
import re
from dataclasses import dataclass, replace
from pathlib import Path

from onepiece_dist.errors import SourceError
from onepiece_dist.objects.manifest import MANIFEST, Manifest, ObjectSettings, read_manifest
from onepiece_dist.objects.paths import PACKAGE_MAP, package_folders
from onepiece_dist.objects.shapes import SETS, shape_parameters
from onepiece_dist.objects.urdf import mesh_filenames

MESH_SUFFIXES = (".obj", ".stl", ".ply", ".glb")
OBJECT_SUFFIXES = (*MESH_SUFFIXES, ".urdf")
COMPANION_SUFFIXES = (".mtl", ".png", ".jpg", ".jpeg", ".tga", ".bmp", ".gif", ".txt", ".md", ".dae", ".json")

# name -> (path inside pybullet_data, scale applied to a bare mesh)
PYBULLET_NAMED = {
    "bunny": ("bunny.obj", 0.06),
    "cube_small": ("cube_small.urdf", 1.0),
    "domino": ("domino/domino.urdf", 1.0),
    "duck": ("duck_vhacd.urdf", 1.0),
    "jenga": ("jenga/jenga.urdf", 1.0),
    "lego": ("lego/lego.urdf", 1.0),
    "mug": ("objects/mug.urdf", 1.0),
    "sphere_small": ("sphere_small.urdf", 1.0),
    "teddy": ("teddy_vhacd.urdf", 1.0),
}

# name -> (kind, dimensions in metres)
PRIMITIVES = (
    ("box_40x30x60", "box", (0.04, 0.03, 0.06)),
    ("box_20x50x50", "box", (0.02, 0.05, 0.05)),
    ("box_60x60x15", "box", (0.06, 0.06, 0.015)),
    ("cylinder_r20_h80", "cylinder", (0.02, 0.08)),
    ("cylinder_r30_h30", "cylinder", (0.03, 0.03)),
    ("cylinder_r10_h120", "cylinder", (0.01, 0.12)),
    ("sphere_r25", "sphere", (0.025,)),
    ("sphere_r35", "sphere", (0.035,)),
)

_SLICE = re.compile(r"^(?P<base>[^\[\]]+?)(?:\[(?P<start>-?\d*):(?P<stop>-?\d*)\])?$")


@dataclass(frozen=True)
class ObjectRef:
    """One object to ingest. ``path`` is a file for kind 'mesh'/'urdf'; ``root`` bounds every file it may open."""

    name: str
    kind: str  # "mesh" | "urdf" | "primitive" | "unsupported"
    path: str = ""
    root: str = ""
    scale: float = 1.0
    primitive: tuple = ()
    units_known: bool = False  # pybullet_data's sets, or a folder whose manifest names its units: a job's do not apply
    mass: float | None = None  # kg, from the folder's manifest (objects.yaml); None: density x volume
    density: float | None = None  # kg/m^3, from the manifest; None: the job's sim.density
    friction: float | None = None  # the object's own coefficient, from the manifest; None: 1 (the pads' alone)
    grasps: str = ""  # a grasp file made elsewhere (objects.foreign): its grasps are labelled, none sampled
    grasps_digest: str = ""  # of that file's bytes


def resolve_source(source: str) -> list[ObjectRef]:
    """Resolve a source string to object references (deterministic order)."""
    refs: list[ObjectRef] = []
    for part in (p.strip() for p in source.split("+")):
        if not part:
            raise SourceError(f"objects source {source!r} has an empty part")
        refs.extend(_resolve_one(part))
    return refs


def _resolve_one(part: str) -> list[ObjectRef]:
    match = _SLICE.match(part)
    base, window = (match["base"], slice(_int(match["start"]), _int(match["stop"]))) if match else (part, slice(None))
    if base == "pybullet:named":
        return _pybullet_named()[window]
    if base == "pybullet:random_urdfs":
        return _pybullet_random()[window]
    if base == "primitives":
        return [ObjectRef(name, "primitive", primitive=(kind, dims)) for name, kind, dims in PRIMITIVES][window]
    if base.startswith("shapes:"):
        return _shapes(base[len("shapes:"):], window)
    if base.startswith("grasps:"):
        return [foreign_ref(base[len("grasps:"):])]
    if base.startswith("pybullet:"):
        raise SourceError(f"unknown built-in set {base!r}; known: pybullet:named, pybullet:random_urdfs[a:b], "
                          f"{', '.join(f'shapes:{name}[a:b]' for name in SETS)}")
    if os.path.isdir(part):
        return folder_refs(Path(part))
    if glob.has_magic(part):
        return _glob_refs(part)
    if os.path.isfile(part):
        path = Path(part)
        return [_file_ref(path, path.parent)]
    raise SourceError(f"objects source {part!r} is neither a built-in set, a folder, a file nor a glob")


def _int(text: str | None) -> int | None:
    return int(text) if text else None


def _shapes(set_name: str, window: slice) -> list[ObjectRef]:
    if set_name not in SETS:
        raise SourceError(f"unknown shape set 'shapes:{set_name}'; known: "
                          f"{', '.join(f'shapes:{name}[a:b]' for name in SETS)}")
    return [ObjectRef(name, "primitive", primitive=(kind, sizes))
            for name, kind, sizes in shape_parameters(set_name, window)]


def _pybullet_root() -> Path:
    import pybullet_data  # data only; does not import pybullet

    return Path(pybullet_data.getDataPath())


def _pybullet_named() -> list[ObjectRef]:
    root = _pybullet_root()
    return [ObjectRef(name, _kind(Path(rel)), str(root / rel), str((root / rel).parent), scale,
                      units_known=True)
            for name, (rel, scale) in sorted(PYBULLET_NAMED.items())]


def _pybullet_random() -> list[ObjectRef]:
    root = _pybullet_root() / "random_urdfs"
    urdfs = sorted(root.glob("[0-9][0-9][0-9]/[0-9][0-9][0-9].urdf"))
    return [ObjectRef(f"random_urdfs/{p.stem}", "urdf", str(p), str(p.parent), units_known=True) for p in urdfs]


def folder_refs(folder: Path) -> list[ObjectRef]:
    """Every object file under ``folder`` (recursively); meshes referenced by a URDF there are not listed
    twice; companion files (materials, textures) are skipped; anything else is listed as unsupported so
    that it gets a rejection with a reason."""
    files = sorted(p for p in folder.rglob("*") if p.is_file() or p.is_symlink())
    claimed = _urdf_claimed_meshes((f for f in files if f.suffix.lower() == ".urdf"), folder)
    manifest = read_manifest(folder)
    refs = []
    for path in files:
        if path.suffix.lower() in COMPANION_SUFFIXES or path.name in (PACKAGE_MAP, MANIFEST) or \
                Path(os.path.normpath(path)) in claimed:
            continue
        refs.append(_with_manifest(_file_ref(path, folder), manifest))
    return refs


def _with_manifest(ref: ObjectRef, manifest: Manifest | None) -> ObjectRef:
    """``ref`` with its folder manifest's units and its own settings (none: as it was)."""
    if manifest is None:
        return ref
    own = manifest.objects.get(ref.name, ObjectSettings())
    units = manifest.unit_scale
    return replace(ref, scale=ref.scale * own.scale * (units or 1.0), units_known=units is not None,
                   mass=own.mass, density=own.density, friction=own.friction)


def _glob_refs(pattern: str) -> list[ObjectRef]:
    root = Path(pattern.split("*")[0].split("?")[0].split("[")[0] or ".")
    root = root if root.is_dir() else root.parent
    files = sorted(Path(p) for p in glob.glob(pattern, recursive=True) if os.path.isfile(p) or os.path.islink(p))
    if not files:
        raise SourceError(f"glob {pattern!r} matches no files")
    return [_file_ref(p, root) for p in files]


def foreign_ref(path: str) -> ObjectRef:
    """The object of an ACRONYM or GraspGen grasp file (``grasps:PATH``): its mesh at the file's scale, with the
    file's grasps to label instead of sampled ones (objects.foreign)."""
    from onepiece_dist.objects.foreign import read_foreign_grasps

    found = read_foreign_grasps(path)
    return ObjectRef(found.path.stem, _kind(found.mesh), str(found.mesh), str(found.root), scale=found.scale,
                     units_known=True, grasps=str(found.path), grasps_digest=found.digest)


def _file_ref(path: Path, root: Path) -> ObjectRef:
    name = str(path.relative_to(root)) if path.is_relative_to(root) else path.name
    return ObjectRef(name, _kind(path), str(path), str(root))


def _kind(path: Path) -> str:
    suffix = path.suffix.lower()
    if suffix == ".urdf":
        return "urdf"
    return "mesh" if suffix in MESH_SUFFIXES else "unsupported"


def _urdf_claimed_meshes(urdfs, root: Path) -> set[Path]:
    """Paths of the mesh files that the given URDFs name, read with the XML parser (best effort; bad URDFs and
    paths are judged, and rejected with a reason, at load time)."""
    claimed: set[Path] = set()
    for urdf in urdfs:
        real = Path(os.path.realpath(urdf))
        if not real.is_relative_to(os.path.realpath(urdf.parent)):
            continue  # a symlink out of the folder: never opened, rejected at load time
        try:
            text = real.read_text(errors="replace")[:1_000_000]
        except OSError:
            continue
        for name in mesh_filenames(text):
            if name.startswith("package://"):
                package, _, rest = name[len("package://"):].partition("/")
                folder = package_folders(root).get(package)
                if folder is not None:
                    claimed.add(Path(os.path.normpath(root / folder / rest)))
            elif "://" not in name and not os.path.isabs(name):
                claimed.add(Path(os.path.normpath(urdf.parent / name)))
    return claimed
