import ast
import re
import subprocess
import sys
from pathlib import Path

import pytest

from onepiece_dist.cli.schema_files import render_array_table, render_example_job, render_format_page, render_schemas

ROOT = Path(__file__).resolve().parents[1]


def test_core_imports_no_simulator_store_ray_or_torch():
    code = ("import sys, onepiece_dist.core.frames, onepiece_dist.core.voxel, onepiece_dist.core.dedup, "
            "onepiece_dist.core.mesh, onepiece_dist.core.sampling; "
            "print(sorted(m for m in ('pybullet', 'zarr', 'ray', 'torch') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


PACKAGE = ROOT / "onepiece_dist"
# Each room (a folder at the package's top, or a loose module) and what it may import: rooms below it, and the
# third-party libraries it is allowed to use. The base rooms (errors, specs, version) sit under every room.
BASE = {"errors", "specs", "version"}
LAYERS: dict[str, tuple[set[str], set[str]]] = {
    "errors": (set(), set()),
    "version": (set(), set()),
    "gripper": ({"errors"}, {"numpy", "trimesh"}),  # the presets, and a gripper from a URDF's finger links
    "specs": ({"errors", "gripper"}, {"pydantic", "yaml"}),  # every frozen spec, on specs.frozen
    "stats": (set(), {"numpy"}),  # intervals, ranking, a label's ceiling, selection: pure numpy
    "core": (BASE, {"numpy", "open3d", "scipy"}),  # imported where used: open3d's ray casts, scipy's N-d qhull
    "objects": (BASE | {"core"}, {"numpy", "open3d", "trimesh", "pybullet_data", "pydantic", "yaml",
                                  "h5py"}),  # h5py: ACRONYM grasp files brought in (objects.foreign)
    "sim": (BASE | {"core", "stats", "objects"}, {"numpy", "pybullet", "pybullet_data"}),
    "store": ({"errors"}, {"numpy", "zarr", "pydantic"}),
    "learn": ({"errors", "specs", "store", "core", "stats"}, {"numpy", "torch", "zarr"}),
    # planning on a camera's cloud: candidates, crops as the training's, the network's scores, the picture
    "plan": (BASE | {"core", "learn"}, {"numpy", "torch", "open3d", "matplotlib"}),
    # the job: its pipeline, contracts and status; stages/ (what a worker or the writer does), exports/ (files only
    # the CLI writes); no Ray: where the work runs is the runtime's
    "job": (BASE | {"core", "stats", "objects", "sim", "store", "learn", "plan"},
            {"numpy", "torch", "pybullet", "pybullet_data", "pydantic", "yaml",
             "h5py"}),  # h5py: the ACRONYM export only (the formats extra)
    # where every job's work runs: in process, a pinned child, Ray's actors and pools
    "runtime": (BASE | {"core", "stats", "objects", "sim", "store", "learn", "plan", "job"},
                {"numpy", "ray", "torch", "pybullet", "pybullet_data", "pydantic", "yaml", "psutil"}),
    # the pick benchmark: one object's views and choosers, a task per object on the runtime's worker pool
    "picks": (BASE | {"core", "stats", "objects", "sim", "store", "plan", "job", "runtime"},
              {"numpy", "ray", "torch", "pydantic"}),
    "api": (BASE | {"objects", "job", "runtime", "picks", "plan", "store", "learn"}, {"ray"}),  # learn: lazily
    # the study wing: arms, held-out evaluation, statistics, decision, pages; nothing below it imports it
    "study": (BASE | {"api", "job", "runtime", "picks", "learn", "store", "core", "stats", "objects", "sim"},
              {"numpy", "pydantic", "yaml", "ray", "torch", "matplotlib"}),
    # the command, one module per group; schema_files writes the models' schemas and the pages rendered from them
    "cli": (BASE | {"gripper", "api", "objects", "sim", "job", "runtime", "picks", "plan", "store", "study"},
            {"typer", "rich", "yaml", "pydantic", "numpy"}),
}
LOOSE_AT_MOST, MODULES_PER_FOLDER = 5, 18
STDLIB = set(sys.stdlib_module_names)


def imports_of(path: Path) -> set[str]:
    """Top-level names (``onepiece_dist.X`` as ``onepiece_dist.X``) of every import in a module, lazy ones too."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            modules = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            modules = [node.module]
        else:
            continue
        for module in modules:
            parts = module.split(".")
            names.add(".".join(parts[:2]) if parts[0] == "onepiece_dist" else parts[0])
    return names


def layer_of(path: Path) -> str:
    relative = path.relative_to(PACKAGE).parts
    return relative[0] if len(relative) > 1 else path.stem


MODULES = sorted(p for p in PACKAGE.rglob("*.py") if p.name != "__init__.py" or p.parent != PACKAGE)


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_every_module_imports_only_its_layer_and_those_below(path):
    layer = layer_of(path)
    below, libraries = LAYERS[layer]
    names = imports_of(path)
    quiet = path.name == "__init__.py" or path.stat().st_size < 200  # a room's docstring, a tiny module
    assert names or quiet, f"{path}: no import found in a module with code (the parser broke?)"
    for name in names - STDLIB - {"__future__"}:
        if name.startswith("onepiece_dist."):
            target = name.split(".")[1]
            assert target in below | {layer}, f"{path.relative_to(ROOT)}: layer {layer} imports {name}"
        else:
            assert name in libraries, f"{path.relative_to(ROOT)}: layer {layer} imports {name}"


def test_the_layer_guard_sees_a_forbidden_import(tmp_path):
    module = tmp_path / "bad.py"
    module.write_text("def f():\n    import ray\n    from onepiece_dist.job import pipeline\n")
    assert imports_of(module) == {"ray", "onepiece_dist.job"}


@pytest.mark.parametrize("name", sorted(render_schemas()))
def test_committed_schemas_match_models(name):
    committed = (ROOT / "schemas" / name).read_text()
    assert committed == render_schemas()[name], f"schemas/{name} drifted: run `onepiece schema`"


def test_the_format_page_lists_every_array_and_attribute_the_layout_names():
    page = (ROOT / "docs" / "dataset_format.md").read_text()
    assert render_format_page(page) == page, "docs/dataset_format.md drifted: run `onepiece schema`"
    assert render_array_table() in page and "| `assembly_labels` | no |" in page


def test_the_example_job_lists_every_field_at_its_default():
    from onepiece_dist.specs.job import JobSpec, load_job_spec

    example = ROOT / "examples" / "job.yaml"
    assert example.read_text() == render_example_job(), "examples/job.yaml drifted: run `onepiece schema`"
    assert load_job_spec(example, {}) == JobSpec()
    for name in JobSpec.model_fields:
        assert f"\n{name}:" in example.read_text(), name


def benchmark_imports() -> dict[str, set[str]]:
    """{benchmarks module: the benchmarks modules it imports, lazy ones too}, as dotted names below ``benchmarks``
    (``speed.bench_merge``); ``from benchmarks.pages import report`` counts as ``pages.report``."""
    folder = ROOT / "benchmarks"
    graph = {}
    for path in folder.rglob("*.py"):
        found = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("benchmarks."):
                module = node.module.removeprefix("benchmarks.")
                found |= {f"{module}.{a.name}" if (folder / module.replace(".", "/") / f"{a.name}.py").exists()
                          else module for a in node.names}
            elif isinstance(node, ast.ImportFrom) and node.module == "benchmarks":
                found |= {alias.name for alias in node.names}
        graph[".".join(path.relative_to(folder).with_suffix("").parts)] = found
    return graph


def test_benchmarks_import_each_other_without_a_circle_or_a_path_trick():
    """Issue 38: the scripts in benchmarks/ form no import circle, and nothing in benchmarks/ or tests/ edits
    sys.path to reach a module (benchmarks is a package, the checkout's package is installed)."""
    graph = benchmark_imports()
    assert graph["pages.report"] and graph["pages.scaling_page"] == {"pages.committed"}, graph  # the guard sees imports

    def reaches(start: str, target: str, seen: frozenset = frozenset()) -> bool:
        return any(d == target or (d not in seen and reaches(d, target, seen | {d})) for d in graph.get(start, ()))

    assert [m for m in graph if reaches(m, m)] == []
    tricks = [f"{path.relative_to(ROOT)}:{node.lineno}" for folder in ("benchmarks", "tests")
              for path in (ROOT / folder).rglob("*.py") for node in ast.walk(ast.parse(path.read_text()))
              if edits_sys_path(node)]
    assert tricks == []


def edits_sys_path(node: ast.AST) -> bool:
    """A call of a method of ``sys.path`` that adds to it (insert, append, extend)."""
    target = node.func if isinstance(node, ast.Call) else None
    return (isinstance(target, ast.Attribute) and target.attr in ("insert", "append", "extend")
            and isinstance(target.value, ast.Attribute) and target.value.attr == "path"
            and isinstance(target.value.value, ast.Name) and target.value.value.id == "sys")


def package_import_graph() -> dict[str, set[str]]:
    """{module: the package's modules it imports, lazy ones too}, as dotted names under ``onepiece_dist``; ``from
    onepiece_dist.a import b`` counts as importing ``a.b`` where that is a module, else ``a``."""
    modules = {".".join(p.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__"): p
               for p in PACKAGE.rglob("*.py")}
    graph = {}
    for name, path in modules.items():
        found = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.level == 0 and (node.module or "").startswith("onepiece_"):
                found |= {f"{node.module}.{a.name}" if f"{node.module}.{a.name}" in modules else node.module
                          for a in node.names}
            elif isinstance(node, ast.Import):
                found |= {a.name for a in node.names if a.name in modules}
        graph[name] = found & modules.keys() - {name}
    return graph


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """One path per module that leads back to itself through ``graph``."""
    found = []
    for start in sorted(graph):
        stack, seen = [(start, [start])], set()
        while stack:
            node, path = stack.pop()
            for target in sorted(graph.get(node, ())):
                if target == start:
                    found.append([*path, start])
                    stack = []
                    break
                if target not in seen:
                    seen.add(target)
                    stack.append((target, [*path, target]))
    return found


def test_no_module_of_the_package_imports_itself_through_others():
    """Issue 48: no import circle anywhere in the package, lazy imports counted (a circle the guard can see)."""
    graph = package_import_graph()
    assert graph["onepiece_dist.runtime.local"] >= {"onepiece_dist.job.pipeline"}, "the graph sees imports"
    assert circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}})[0] == ["a", "b", "c", "a"]
    assert circles(graph) == []


def test_the_job_stages_and_exports_import_nothing_from_the_runtime():
    """Issue 48: a stage is what a worker or the writer does, whatever runs it; the runtimes (in process, a pinned
    child, Ray) call the stages, never the other way round, and neither stages nor exports reach the pipeline."""
    graph = package_import_graph()
    rooms = ("onepiece_dist.job.stages.", "onepiece_dist.job.exports.")
    stages = [m for m in graph if m.startswith(rooms)]
    assert len(stages) >= 12, stages
    reaching = {m: sorted(t for t in graph[m] if t.startswith("onepiece_dist.runtime")
                          or t == "onepiece_dist.job.pipeline") for m in stages}
    assert {m: t for m, t in reaching.items() if t} == {}
    runtimes = [m for m in graph if m.startswith("onepiece_dist.runtime.")]
    assert any(t.startswith("onepiece_dist.job.stages.") for m in runtimes for t in graph[m])  # the rule can see


HEAVY = {"numpy", "ray", "torch", "pybullet", "pybullet_data", "zarr", "open3d", "scipy", "matplotlib", "h5py",
         "trimesh", "coacd", "psutil", "typer", "rich", "yaml", "pydantic", "jsonschema"}


def module_level_imports(tree: ast.Module, modules: set[str]) -> tuple[set[str], set[str]]:
    """(our modules, third-party top-level names) a module imports when it loads: not inside functions, not under
    ``if TYPE_CHECKING``."""
    ours, third = set(), set()

    def visit(body: list[ast.stmt]) -> None:
        for node in body:
            if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
                continue
            if isinstance(node, ast.If | ast.Try):
                for block in (node.body, node.orelse, getattr(node, "finalbody", []),
                              *[h.body for h in getattr(node, "handlers", [])]):
                    visit(block)
            elif isinstance(node, ast.Import):
                for alias in node.names:
                    (ours if alias.name in modules else third).add(alias.name if alias.name in modules
                                                                    else alias.name.split(".")[0])
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                if node.module.startswith("onepiece_dist"):
                    ours.update(imported_module(node.module, a.name, modules) for a in node.names)
                else:
                    third.add(node.module.split(".")[0])

    visit(tree.body)
    return ours & modules, third


def imported_module(module: str, name: str, modules: set[str]) -> str:
    return f"{module}.{name}" if f"{module}.{name}" in modules else module


def needless_lazy_imports() -> list[str]:
    """In-function imports of our own modules that keep nothing out: the module they import brings no heavy
    library (HEAVY) the importing module does not load already, and importing it at module level makes no
    circle."""
    paths = {".".join(p.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__"): p
             for p in PACKAGE.rglob("*.py")}
    trees = {name: ast.parse(path.read_text()) for name, path in paths.items()}
    loads = {}
    for name, tree in trees.items():
        ours, third = module_level_imports(tree, set(paths))
        parents = {".".join(name.split(".")[:i]) for i in range(2, name.count(".") + 1)}
        loads[name] = (ours | parents) & set(paths), third & HEAVY

    def closure(name: str) -> tuple[set[str], set[str]]:
        seen, heavy, todo = set(), set(), [name]
        while todo:
            current = todo.pop()
            if current not in seen:
                seen.add(current)
                heavy |= loads[current][1]
                todo += loads[current][0]
        return seen, heavy

    found = []
    for name, tree in trees.items():
        heavy_here = closure(name)[1]
        for function in (n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef)):
            for node in ast.walk(function):
                if isinstance(node, ast.ImportFrom) and node.level == 0 and (node.module or "").startswith("onepie"):
                    for target in {imported_module(node.module, a.name, set(paths)) for a in node.names} & set(paths):
                        reached, heavy = closure(target)
                        if name not in reached and heavy <= heavy_here:
                            found.append(f"{paths[name].relative_to(ROOT)}:{node.lineno} imports {target}")
    return found


def test_a_function_imports_our_modules_only_to_keep_a_heavy_library_or_a_circle_out():
    """Issue 48: 222 in-function imports of our own modules, 119 of which kept nothing heavy out (101 moved to
    module level; 105 remain, each keeping ray, torch, pybullet, zarr or another heavy library off a light path,
    or an import circle away)."""
    assert needless_lazy_imports() == []


def test_the_lazy_import_check_sees_a_needless_one(tmp_path, monkeypatch):
    package = tmp_path / "onepiece_dist"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "light.py").write_text("import json\n")
    (package / "heavy.py").write_text("import torch\n")
    (package / "user.py").write_text("def f():\n    from onepiece_dist.light import x\n"
                                     "def g():\n    from onepiece_dist.heavy import y\n")
    monkeypatch.setattr(sys.modules[__name__], "PACKAGE", package)
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    assert needless_lazy_imports() == ["onepiece_dist/user.py:2 imports onepiece_dist.light"]


def test_the_readme_layout_table_names_every_layer_and_benchmark_folder_there_is():
    """Issue 48: the README's layout table is true: every layer of the package (a folder, or a module the layer
    table lists as one of several) and every folder of benchmarks/ is named in it, and every one it names exists."""
    readme = (ROOT / "README.md").read_text()
    table = readme[readme.index("## Layout"):]
    package_row = next(line for line in table.splitlines() if line.startswith("| `onepiece_dist/` |")).split("|")[2]
    folders = {p.name for p in PACKAGE.iterdir() if p.is_dir() and (p / "__init__.py").exists()}
    named = set(re.findall(r"`([a-z_]+)`", package_row))
    assert folders - named == set(), "layers missing from the README's layout table"
    assert {"api", "errors"} <= named and named - folders - {"api", "errors"} <= {"pipeline.py"}, named - folders
    for name in re.findall(r"`([a-z_]+)/`", package_row):
        assert (PACKAGE / "job" / name).is_dir() or (PACKAGE / "core" / name).is_dir(), name
    bench_row = next(line for line in table.splitlines() if line.startswith("| `benchmarks/` |")).split("|")[2]
    bench = {p.name for p in (ROOT / "benchmarks").iterdir() if p.is_dir() and (p / "__init__.py").exists()}
    assert set(re.findall(r"`([a-z_]+)/`", bench_row)) == bench


def test_the_package_has_rooms_at_its_top_and_no_crowded_folder():
    """Issue 57: at most LOOSE_AT_MOST modules loose at the package's top (the API, errors, the version), every
    other module in a room; no folder holds more than MODULES_PER_FOLDER modules; every room is in LAYERS."""
    loose = sorted(p.stem for p in PACKAGE.glob("*.py") if p.name != "__init__.py")
    assert 0 < len(loose) <= LOOSE_AT_MOST, loose
    folders = [PACKAGE, *(p for p in PACKAGE.rglob("*") if p.is_dir() and (p / "__init__.py").exists())]
    crowded = {str(f.relative_to(ROOT)): n for f in folders
               if (n := sum(1 for p in f.glob("*.py") if p.name != "__init__.py")) > MODULES_PER_FOLDER}
    assert crowded == {}
    rooms = {p.name for p in PACKAGE.iterdir() if p.is_dir() and (p / "__init__.py").exists()}
    assert rooms | set(loose) == set(LAYERS), sorted((rooms | set(loose)) ^ set(LAYERS))
