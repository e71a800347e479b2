"""The paper experiment's arms trained again with a larger budget (issue 17, item 7), on a GPU where one is lent.

The 2-core run trains every arm for 500 gradient steps of 64 grasps (32,000 samples), and its best checkpoints
are often its last ones. Here arms train for ``--steps`` of ``--batch-size`` on the same train rows, validation
splits and held-out grasps, at the learning rate chosen on the arm's validation split (seed 0 at each of
``--rates``, or ``--rates chosen``: the one the 2-core run's search picked), so one can see whether the
comparison of A, B and R depends on the training budget.

    python -m benchmarks.experiment_longer export --folder /tmp/exp-grasp \
        --results benchmarks/results/paper_experiment_grasp_load.json --to .gpu/grasp_load.npz
    python -m benchmarks.experiment_longer train --data .gpu/grasp_load.npz --out OUT     (GPU: 7 processes)
    python -m benchmarks.experiment_longer train --data .gpu/grasp_load.npz --out OUT --device cpu --workers 2 \
        --steps 2000 --batch-size 64 --rates chosen --arms "A,B r0,R r0"                 (this 2-core machine)
    python -m benchmarks.experiment_longer report --data .gpu/grasp_load.npz --runs OUT \
        --results benchmarks/results/paper_experiment_grasp_load.json --train-command "..."

``export`` (here: zarr, the results file and the experiment's folder) writes one ``.npz`` (no pickles): each
dataset's gripper-frame points as int8 (one scale for all, about 0.3 mm steps), its labels, and each training
run's train and validation rows exactly as ``experiment_learn.fit_and_score`` draws them. ``train`` needs torch
and numpy only (the GPU machine has neither zarr nor pydantic) and writes each arm's held-out scores. ``report``
scores them with the statistics of ``experiment_learn`` and writes ``benchmarks/results/NAME_longer.json`` and
``docs/NAME_longer.md``.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from onepiece_dist.study.markdown import in_words  # standard library only: runs on the GPU machine too

ROOT = Path(__file__).resolve().parents[1]
QUANT = 127  # int8 steps on each side of zero


def _dataset_key(path: str) -> str:
    return Path(path).name.removesuffix(".zarr").replace("-", "_")


def export(folder: Path, results: dict, to: Path) -> dict:
    """Write the arms' data of the experiment in ``folder`` (its results file ``results``) to ``to``."""
    from benchmarks.paper_experiment import train_jobs

    args = argparse.Namespace(**results["args"])
    jobs = train_jobs(args, results["arms"], folder, 0.0)
    paths = {_dataset_key(j.path): (j.path, j.group) for j in jobs} | {"heldout": (str(folder / "heldout.zarr"),
                                                                                   "grasps")}
    arrays, plan = _dataset_arrays(paths), []
    rate_of = {row["arm"]: row["learning_rate"] for row in results["arms"]}
    for job in jobs:
        train, val = _split(job)
        key = f"{job.arm.replace(' ', '_')}_{job.seed}"
        arrays[f"train_{key}"], arrays[f"val_{key}"] = train, val
        plan.append({"arm": job.arm, "seed": job.seed, "data": _dataset_key(job.path), "key": key,
                     "cpu_learning_rate": rate_of[job.arm]})
    arrays["plan"] = np.array(json.dumps({"runs": plan, "source": results["args"].get("name", "paper_experiment"),
                                          "cpu_steps": args.steps, "cpu_batch": args.batch_size}))
    to.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(to, **arrays)
    return {"bytes": to.stat().st_size, "runs": len(plan)}


def _dataset_arrays(paths: dict[str, tuple[str, str]]) -> dict[str, np.ndarray]:
    """points_KEY (n, P, 3) int8, success_KEY (n,) uint8 and groups_KEY (n,) int64 per dataset, and ``scale``
    (metres per int8 step, one for all)."""
    import zarr

    groups = {key: zarr.open_group(path, mode="r")[group] for key, (path, group) in paths.items()}
    points = {key: g["points"][:].astype(np.float32) for key, g in groups.items()}
    scale = max(float(np.abs(p).max()) for p in points.values()) / QUANT
    out = {"scale": np.float64(scale)}
    for key, g in groups.items():
        out[f"points_{key}"] = np.round(points[key] / scale).astype(np.int8)
        out[f"success_{key}"] = g["success"][:].astype(np.uint8)
        out[f"groups_{key}"] = g["patch" if "patch" in g else "object"][:].astype(np.int64)
    return out


def _split(job) -> tuple[np.ndarray, np.ndarray]:
    """The train and validation rows of ``job``, drawn as ``experiment_learn.fit_and_score`` draws them."""
    from onepiece_dist.learn.dataset import GraspDataset

    full = GraspDataset(job.path, job.group, rows=job.rows, inputs=("points",))
    train, val = full.split_by_group(job.validation, job.seed)
    rows = val.rows
    if len(rows) > job.validation_cap:
        rows = np.sort(np.random.default_rng([job.seed, 13]).choice(rows, job.validation_cap, replace=False))
    return train.rows.astype(np.int64), rows.astype(np.int64)


# ---- training: torch and numpy only (the GPU machine has neither zarr nor pydantic) ----------------------------


def _pointnet():
    """The package's PointNetGrasp (``onepiece_dist.learn.models`` imports with torch alone)."""
    from onepiece_dist.learn.models import PointNetGrasp

    return PointNetGrasp


class ArmData:
    """One arm's tensors on ``device``: its dataset's points (int8) and labels, and the held-out grasps."""

    def __init__(self, data, key: str, device):
        import torch

        def tensor(name):
            return torch.from_numpy(np.ascontiguousarray(data[name])).to(device)

        self.scale = float(data["scale"])
        self.points, self.labels = tensor(f"points_{key}"), tensor(f"success_{key}").float()
        self.heldout = tensor("points_heldout")

    def batch(self, rows):
        return {"points": self.points[rows].float() * self.scale}

    def heldout_batch(self, rows):
        return {"points": self.heldout[rows].float() * self.scale}


def fit(arm: ArmData, train, val, rate: float, seed: int, steps: int, batch: int, evaluations: int) -> dict:
    """``steps`` Adam steps on uniform draws of ``train`` rows; the checkpoint with the lowest validation loss
    scores every held-out grasp. train, val: (n,) int64 tensors of rows on the arm's device."""
    import torch

    torch.manual_seed(seed)
    model = _pointnet()().to(arm.points.device)
    optimiser = torch.optim.Adam(model.parameters(), lr=rate)
    draw = torch.Generator(device=arm.points.device).manual_seed(seed)
    best, state, curve, every, start = float("inf"), None, [], max(1, steps // evaluations), time.perf_counter()
    for k in range(1, steps + 1):
        model.train()
        rows = train[torch.randint(len(train), (min(batch, len(train)),), generator=draw, device=train.device)]
        loss = torch.nn.functional.binary_cross_entropy_with_logits(model(arm.batch(rows)), arm.labels[rows])
        optimiser.zero_grad(set_to_none=True)
        loss.backward()
        optimiser.step()
        if k % every == 0 or k == steps:
            val_loss = _loss(model, arm, val)
            curve.append({"step": k, "val_loss": round(val_loss, 4)})
            if val_loss < best:
                best, state = val_loss, {n: t.detach().clone() for n, t in model.state_dict().items()}
    model.load_state_dict(state)
    return {"seed": seed, "learning_rate": rate, "best_val_loss": best, "curve": curve,
            "train_seconds": round(time.perf_counter() - start, 1), "train_grasps": len(train),
            "best_step": min(curve, key=lambda c: c["val_loss"])["step"],
            "scores": _probabilities(model, arm.heldout_batch, len(arm.heldout))}


def _probabilities(model, batch_of, n: int, size: int = 4096) -> np.ndarray:
    import torch

    model.eval()
    with torch.no_grad():
        device = next(model.parameters()).device
        out = [torch.sigmoid(model(batch_of(torch.arange(i, min(i + size, n), device=device))))
               for i in range(0, n, size)]
    return torch.cat(out).float().cpu().numpy()


def _loss(model, arm: ArmData, rows) -> float:
    import torch

    scores = torch.from_numpy(_probabilities(model, lambda r: arm.batch(rows[r]), len(rows)))
    return torch.nn.functional.binary_cross_entropy(scores.clamp(1e-6, 1 - 1e-6), arm.labels[rows].cpu()).item()


_LOADED: dict = {}  # (data path, dataset key, device) -> ArmData, per worker process


def train_run(data_path: str, run: dict, rate: float, opts: dict) -> dict:
    """One training run of the plan (``run``: arm, seed, data, key) at ``rate``; ``opts``: steps, batch_size,
    evaluations, device, threads."""
    import torch

    torch.set_num_threads(opts["threads"])
    where = torch.device(opts["device"])
    data = np.load(data_path, allow_pickle=False)
    if (data_path, run["data"], opts["device"]) not in _LOADED:
        _LOADED[(data_path, run["data"], opts["device"])] = ArmData(data, run["data"], where)
    arm = _LOADED[(data_path, run["data"], opts["device"])]

    def rows(name):
        return torch.from_numpy(data[name]).to(where)

    return {"arm": run["arm"], **fit(arm, rows(f"train_{run['key']}"), rows(f"val_{run['key']}"), rate,
                                     run["seed"], opts["steps"], opts["batch_size"], opts["evaluations"]),
            "device": torch.cuda.get_device_name(0) if where.type == "cuda" else "cpu", "torch": torch.__version__}


def train_all(args) -> list[str]:
    """Seed 0 of every arm at each rate, then the other seeds at the rate of the lowest validation loss (with one
    rate per arm, as ``--rates chosen``, every seed at once); ``--workers`` processes (on one GPU, small launch-bound
    batches from several processes fill it). Writes ``out/arm_ARM.npz`` per arm: scores (seeds, heldout) and a
    JSON record of its runs."""
    from concurrent.futures import ProcessPoolExecutor
    from multiprocessing import get_context

    plan = json.loads(str(np.load(args.data, allow_pickle=False)["plan"]))["runs"]
    chosen = args.arms.split(",") if args.arms else list(dict.fromkeys(r["arm"] for r in plan))
    runs = {arm: sorted((r for r in plan if r["arm"] == arm), key=lambda r: r["seed"]) for arm in chosen}
    opts = {"steps": args.steps, "batch_size": args.batch_size, "evaluations": args.evaluations,
            "device": args.device, "threads": args.threads}
    start, written = time.perf_counter(), []
    with ProcessPoolExecutor(args.workers, mp_context=get_context("spawn")) as pool:
        def submit(run, rate):
            return pool.submit(train_run, args.data, run, rate, opts)

        search = {arm: [submit(rs[0], rate) for rate in _rates(args.rates, rs[0])] for arm, rs in runs.items()}
        rest = {arm: [submit(r, _rest_rate(search[arm], args.rates, rs[0])) for r in rs[1:]]
                for arm, rs in runs.items()}
        for arm, futures in rest.items():
            probes = [f.result() for f in search[arm]]
            done = [_lowest(probes)] + [f.result() for f in futures]
            written.append(_write_arm(Path(args.out), arm, done, probes, opts, time.perf_counter() - start))
            print(f"{arm}: {len(done)} runs written at {time.perf_counter() - start:.0f} s", flush=True)
    return written


def _lowest(probes: list[dict]) -> dict:
    return min(probes, key=lambda d: d["best_val_loss"])


def _rest_rate(futures, rates: str, first: dict) -> float:
    """The other seeds' rate: the only one (submitted at once), or seed 0's best after its search."""
    only = _rates(rates, first)
    return only[0] if len(only) == 1 else _lowest([f.result() for f in futures])["learning_rate"]


def _rates(text: str, run: dict) -> list[float]:
    return [run["cpu_learning_rate"]] if text == "chosen" else [float(r) for r in text.split(",")]


def _arm_file(folder: Path, arm: str) -> Path:
    return folder / f"arm_{arm.replace(' ', '_')}.npz"


def _write_arm(out: Path, arm: str, done: list[dict], probes: list[dict], opts: dict, seconds: float) -> str:
    out.mkdir(parents=True, exist_ok=True)
    record = {"arm": arm, "device": done[0]["device"], "torch": done[0]["torch"], "steps": opts["steps"],
              "batch_size": opts["batch_size"], "evaluations": opts["evaluations"], "seconds": round(seconds, 1),
              "search": [{"learning_rate": p["learning_rate"], "best_val_loss": round(p["best_val_loss"], 4)}
                         for p in probes],
              "runs": [{k: v for k, v in d.items() if k not in ("scores", "device", "torch")} for d in done]}
    target = _arm_file(out, arm)
    np.savez(target, scores=np.stack([d["scores"] for d in done]), record=np.array(json.dumps(record)))
    return str(target)


# ---- here again: score the runs, write the results and the page ------------------------------------------------


def report(data_path: Path, runs_dir: Path, results: dict, command: str, tag: str = "") -> dict:
    """Held-out statistics of the longer runs of every trained arm beside the 2-core run's (``results``); ``tag``
    names a second budget's files (NAME_longer_TAG) beside the first's."""
    from benchmarks.experiment_learn import arm_summary

    data = np.load(data_path, allow_pickle=False)
    labels, groups = data["success_heldout"].astype(np.float64), data["groups_heldout"]
    plan = json.loads(str(data["plan"]))
    arms = []
    for cpu in results["arms"]:
        path = _arm_file(runs_dir, cpu["arm"])
        if not path.exists():  # an arm left out (train --arms)
            continue
        saved = np.load(path, allow_pickle=False)
        record = json.loads(str(saved["record"]))
        runs = [{**run, "scores": scores} for run, scores in zip(record["runs"], saved["scores"], strict=True)]
        arms.append({"arm": cpu["arm"], "labelled_grasps": cpu["labelled_grasps"], "device": record["device"],
                     "learning_rate": runs[0]["learning_rate"], "search": record["search"],
                     "heldout": arm_summary(runs, labels, groups), "cpu_heldout": _brief(cpu["heldout"]),
                     "cpu_learning_rate": cpu["learning_rate"], "seconds": record["seconds"]})
    return {"command": command, "date": time.strftime("%Y-%m-%d"), "source": plan["source"], "tag": tag,
            "device": f"{record['device']}, torch {record['torch']}", "steps": record["steps"],
            "batch_size": record["batch_size"], "evaluations": record["evaluations"], "cpu_steps": plan["cpu_steps"],
            "cpu_batch": plan["cpu_batch"], "arm_seconds": {a["arm"]: a["seconds"] for a in arms},
            "point_step_mm": round(float(data["scale"]) * 1000, 3),
            "heldout": {"objects": int(len(np.unique(groups))),
                                                             "grasps": int(len(labels)),
                                                             "positive_rate": round(float(labels.mean()), 6)},
            "arms": arms}


def longer_name(out: dict) -> str:
    """The stem of the results file and page of ``out``: NAME_longer, or NAME_longer_TAG."""
    return f"{out['source']}_longer" + (f"_{out['tag']}" if out.get("tag") else "")


def _brief(heldout: dict) -> dict:
    return {"top1": heldout["top1"]["mean"], "top1_ci95": heldout["top1"]["ci95"], "ap": heldout["ap"]["mean"],
            "ap_ci95": heldout["ap"].get("ci95")}


def decide(out: dict) -> dict:
    """Which B arms' held-out top-1 lies within A's interval (or above) at the larger budget, and each B against
    the R of its radius (AP and top-1)."""
    arms = {a["arm"]: a["heldout"] for a in out["arms"]}
    low = arms["A"]["top1"]["ci95"][0]
    pairs = {name: {"b_ap": held["ap"]["mean"], "r_ap": arms["R" + name[1:]]["ap"]["mean"],
                    "b_top1": held["top1"]["mean"], "r_top1": arms["R" + name[1:]]["top1"]["mean"]}
             for name, held in arms.items() if name.startswith("B") and "R" + name[1:] in arms}
    return {"a_top1_low": low, "qualifying_b": [n for n in pairs if arms[n]["top1"]["mean"] >= low],
            "b_at_least_r": {n: p["b_ap"] >= p["r_ap"] for n, p in pairs.items()}, "pairs": pairs}


def _pct(x: float) -> str:
    return f"{100 * x:.1f}%"


def _cell(held: dict, ap_ci: list | None) -> list[str]:
    top1 = f"{_pct(held['top1'])} [{_pct(held['top1_ci95'][0])}, {_pct(held['top1_ci95'][1])}]"
    return [top1, f"{held['ap']:.3f}" + (f" [{ap_ci[0]:.3f}, {ap_ci[1]:.3f}]" if ap_ci else "")]


def page(out: dict) -> str:
    """docs/NAME_longer.md, rendered from the results of ``report``."""
    samples, cpu_samples = out["steps"] * out["batch_size"], out["cpu_steps"] * out["cpu_batch"]
    rows = []
    for a in out["arms"]:
        held = a["heldout"]
        longer = {"top1": held["top1"]["mean"], "top1_ci95": held["top1"]["ci95"], "ap": held["ap"]["mean"]}
        steps = sorted(s["best_step"] for s in held["seeds"])
        rows.append("| " + " | ".join([a["arm"], f"{a['labelled_grasps']:,}",
                                       *_cell(a["cpu_heldout"], a["cpu_heldout"]["ap_ci95"]),
                                       *_cell(longer, held["ap"]["ci95"]), f"{held['ap']['std']:.3f}",
                                       f"{a['learning_rate']:g}", f"{steps[len(steps) // 2]:,}"]) + " |")
    lines = [f"# The paper experiment's arms trained {samples / cpu_samples:g}x longer", "",
             f"Command: `{out['command']}` ({out['date']}, {out['device']}). Rendered from "
             f"benchmarks/results/{longer_name(out)}.json by benchmarks/experiment_longer.py.", "",
             f"docs/{out['source']}.md trained every arm for {out['cpu_steps']} gradient steps of {out['cpu_batch']} "
             f"({cpu_samples:,} samples) on 2 cores. Here {_names(out)} train for {out['steps']:,} steps of "
             f"{out['batch_size']} ({samples:,} samples) on the same train rows, validation splits and held-out "
             f"grasps ({out['heldout']['objects']} objects, {out['heldout']['grasps']:,} grasps, positive rate "
             f"{_pct(out['heldout']['positive_rate'])}); {_rate_rule(out)}, the checkpoint the one of the lowest "
             f"validation loss (evaluated {out['evaluations']} times), {len(out['arms'][0]['heldout']['seeds'])} "
             f"seeds. The points travel as int8 ({out['point_step_mm']} mm steps).", "",
             "| arm | labelled grasps | 2-core top-1 (95% CI) | 2-core AP [95% CI] | longer top-1 (95% CI) | "
             "longer AP [95% CI] | longer AP sd over seeds | learning rate | median best step |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- |", *rows, "", "## What it says", "",
             *_verdict(out)]
    return "\n".join(lines) + "\n"


def _names(out: dict) -> str:
    return in_words([a["arm"] for a in out["arms"]])


def _rate_rule(out: dict) -> str:
    if all(len(a["search"]) == 1 and a["learning_rate"] == a["cpu_learning_rate"] for a in out["arms"]):
        return "each arm at the learning rate its validation split picked in the 2-core run"
    rates = sorted({p["learning_rate"] for a in out["arms"] for p in a["search"]})
    return (f"each arm at the learning rate of seed 0's lowest validation loss among "
            f"{', '.join(f'{r:g}' for r in rates)}")


def _verdict(out: dict) -> list[str]:
    d = decide(out)
    qualifying = ", ".join(d["qualifying_b"]) or "none"
    controls = ", ".join(a["arm"] for a in out["arms"] if a["arm"].startswith("R")
                         and a["heldout"]["top1"]["mean"] >= d["a_top1_low"]) or "none"
    lines = [f"- **B within A's interval (top-1 from {_pct(d['a_top1_low'])}):** {qualifying}.",
             f"- **R (a random subset labelled on its own objects) within A's interval:** {controls}."]
    for name, p in d["pairs"].items():
        held = "holds" if d["b_at_least_r"][name] else "does not hold"
        lines.append(f"- **{name} at least as good as R{name[1:]} (AP):** {held}: {p['b_ap']:.3f} against "
                     f"{p['r_ap']:.3f} (top-1 {_pct(p['b_top1'])} against {_pct(p['r_top1'])}).")
    changed = [a["arm"] for a in out["arms"] if abs(a["heldout"]["ap"]["mean"] - a["cpu_heldout"]["ap"]) > 0.02]
    lines.append(f"- **The larger budget moves AP by more than 0.02 for:** {', '.join(changed) or 'no arm'}.")
    rising = [a["arm"] for a in out["arms"]
              if sorted(s["best_step"] for s in a["heldout"]["seeds"])[len(a["heldout"]["seeds"]) // 2] == out["steps"]]
    lines.append("- **Still improving at the last step (median best checkpoint is the last one):** "
                 + (", ".join(rising) + ": a longer run could move them further." if rising else "no arm."))
    return lines


def parse_args(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    ex = sub.add_parser("export", help="the arms' data of an experiment folder, as one .npz")
    ex.add_argument("--folder", type=Path, required=True)
    ex.add_argument("--results", type=Path, required=True)
    ex.add_argument("--to", type=Path, required=True)
    tr = sub.add_parser("train", help="every arm, one process each (torch and numpy only)")
    tr.add_argument("--data", required=True)
    tr.add_argument("--out", required=True)
    tr.add_argument("--steps", type=int, default=8000)
    tr.add_argument("--batch-size", type=int, default=256)
    tr.add_argument("--rates", default="0.0003,0.001,0.003",
                    help="learning rates searched on seed 0's validation split; 'chosen': the 2-core run's")
    tr.add_argument("--arms", default="", help="comma-separated arms (default: all)")
    tr.add_argument("--workers", type=int, default=7, help="training processes")
    tr.add_argument("--threads", type=int, default=1, help="CPU threads per process")
    tr.add_argument("--evaluations", type=int, default=20)
    tr.add_argument("--device", default="cuda")
    rp = sub.add_parser("report", help="score the runs; write the results file and the page")
    rp.add_argument("--data", type=Path, required=True)
    rp.add_argument("--runs", type=Path, required=True)
    rp.add_argument("--results", type=Path, required=True)
    rp.add_argument("--train-command", required=True, help="the train command as it ran, for the page")
    rp.add_argument("--out", type=Path, default=ROOT)
    rp.add_argument("--tag", default="", help="NAME_longer_TAG: a second budget's page beside the first's")
    return parser.parse_args(argv)


def main(argv=None) -> None:
    args = parse_args(argv)
    if args.command == "export":
        print(export(args.folder, json.loads(args.results.read_text()), args.to))
    elif args.command == "train":
        print("\n".join(train_all(args)))
    else:
        out = report(args.data, args.runs, json.loads(args.results.read_text()), args.train_command, args.tag)
        out["decision"] = decide(out)
        target = args.out / "benchmarks" / "results" / f"{longer_name(out)}.json"
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(json.dumps(out, indent=2) + "\n")
        (args.out / "docs").mkdir(parents=True, exist_ok=True)
        (args.out / "docs" / f"{longer_name(out)}.md").write_text(page(out))
        print(target)


if __name__ == "__main__":
    main()
