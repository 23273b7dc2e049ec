"""Speed and memory of darcyan, stage by stage, end to end, and against peers, in one run.

Usage (from the repository root; needs the data at ../shared/data or $DARCYAN_DATA, and the
``[bench]`` extra; the ``pyfm`` peer needs the ``[pyfm]`` extra)::

    python benchmarks/speed.py                      # everything (about 10 minutes on 2 cores)
    python benchmarks/speed.py --sizes 5k --no-scaling --no-profile      # a quick look
    python benchmarks/speed.py --json speed.json    # also keep the raw measurements
    python benchmarks/speed.py --threads-study --repeat 3   # threads, idle and beside a busy neighbour

What is measured, and how:

* Every measurement runs in a fresh child process (``python speed.py --child ...``), so one
  does not inherit another's memory or warm caches.
* **Time**: wall-clock (``time.perf_counter``) and CPU time of the process (user + system,
  ``time.process_time`` in-process, ``wait4`` rusage for whole processes). On a shared machine
  wall time grows with the load (printed with every table); CPU time much less so.
* **Peak memory**: the resident set size high-water mark ``VmHWM`` of the process, which the
  kernel tracks exactly (C++ allocations of potpourri3d/libigl/SuperLU included, unlike
  ``tracemalloc``). Before each stage it is reset by writing ``5`` to ``/proc/self/clear_refs``,
  so a stage's figure is the peak RSS of the whole process *during that stage* (the imported
  libraries and the data still held from earlier stages included). Whole-process figures
  (``darcyan match`` on the command line) are ``ru_maxrss`` from ``wait4``.
* Stages are the pipeline's own (``analyze_mesh``'s progress callback marks their starts):
  load, prepare (checks, repair, largest component, normalization, fast-marching set-up),
  curvature, agd, features, descriptors (grids + descriptors), any stage the pipeline adds later,
  and match. The per-pair figure of a stage is the sum over the two shapes (peak: the larger).
* Peers at the same feature points: HKS and WKS descriptors (``darcyan.eval.baselines``, one
  Laplace-Beltrami eigendecomposition per shape) matched like darcyan's; and the dense pyfm
  pipeline of PyPI's ``pyfmaps`` (its eigenpairs, WKS descriptors, a fitted functional map and
  ZoomOut, converted to a point map). Ratio = peer time / darcyan time on the same basis
  (in-process: load + describe both shapes + match, imports excluded).
* Scaling: one shape described at several resolutions (the synthetic figure at subdivisions
  4..7 and the TOSCA meshes); the exponent ``a`` of ``time ~ c V^a`` is fitted by least squares
  in log-log, for the total and for each stage.
* Profile: cProfile timed by CPU time on the 52k pair (both shapes described and matched): the
  hot spots by self time and the darcyan functions by inclusive time, insensitive to the load
  that other processes put on the machine.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DATA = Path(os.environ.get("DARCYAN_DATA", REPO.parent / "shared" / "data"))

# label -> (source, target), relative to DATA
PAIRS = {
    "5k": ("tosca-5k/cat0.off", "tosca-5k/cat1.off"),
    "27k": ("tosca-hires/cat0.off", "tosca-hires/cat1.off"),
    "52k": ("tosca-hires/david0.off", "tosca-hires/david1.off"),
}
FIGURE_SUBDIVISIONS = (4, 5, 6, 7)  # 2,562 / 10,242 / 40,962 / 163,842 vertices
SCALING_TOSCA = ("tosca-hires/wolf0.off", "tosca-5k/cat0.off", "tosca-hires/horse0.off",
                 "tosca-hires/cat0.off", "tosca-hires/david0.off")
PEERS = ("hks", "wks", "pyfm")
HOT_SPOTS = 15

# The goals of issues 2 and 5.
GOAL_PAIR_ISSUE_2 = 10.0  # s, 52k pair end to end
GOAL_PAIR_ISSUE_5 = 3.0  # s, 52k pair end to end
GOAL_WARM = 0.5  # s, a second match of cached shapes
GOAL_MEMORY_MB = 2048.0  # peak RSS for 52k vertices

MB = 1024.0 * 1024.0


# ------------------------------------------------------------------------------------------------
# Measuring inside a child process


def _reset_peak() -> bool:
    """Reset this process's RSS high-water mark (Linux >= 4.0); False where unsupported."""
    try:
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")
        return True
    except OSError:
        return False


def _peak_mb() -> float:
    """VmHWM of this process in MB (falls back to ru_maxrss, which cannot be reset)."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


class StageMeter:
    """Wall time, CPU time and peak RSS of consecutive stages of this process."""

    def __init__(self) -> None:
        self.stages: dict[str, dict] = {}
        self._current = None

    def start(self, name: str) -> None:
        self.stop()
        _reset_peak()
        self._current = (name, time.perf_counter(), time.process_time())

    def stop(self) -> None:
        if self._current is None:
            return
        name, wall, cpu = self._current
        self.stages[name] = {"wall": time.perf_counter() - wall, "cpu": time.process_time() - cpu,
                             "peak_mb": _peak_mb()}
        self._current = None


def _load(path: str):
    from darcyan.io.mesh_files import load_mesh

    return load_mesh(path)


def _prepared(path: str, meter: StageMeter):
    """Load and prepare (checks, largest component, denoising, normalization), as darcyan does."""
    from darcyan.geometry.shape import prepare_shape

    meter.start("load")
    mesh = _load(path)
    meter.start("prepare")
    shape = prepare_shape(mesh)
    meter.stop()
    return shape.mesh


def _features_in(mesh, input_vertices) -> "list[int]":
    """Input-file vertex indices -> indices of the prepared ``mesh``."""
    position = {int(v): i for i, v in enumerate(mesh.input_index)}
    return [position[int(v)] for v in input_vertices]


def child_pipeline(task: dict) -> dict:
    """Both shapes described stage by stage, then matched (darcyan, in-process)."""
    from darcyan.method.pipeline import analyze_mesh, match_shapes

    shapes, descriptions = [], []
    start_wall, start_cpu = time.perf_counter(), time.process_time()
    for path in task["files"]:
        meter = StageMeter()
        meter.start("load")
        mesh = _load(path)
        meter.stop()
        description = analyze_mesh(mesh, progress=meter.start)
        meter.stop()
        descriptions.append(description)
        shapes.append({"file": path, "n_vertices": mesh.n_vertices, "stages": meter.stages,
                       "features": description.feature_vertices.tolist()})
    meter = StageMeter()
    meter.start("match")
    correspondence = match_shapes(*descriptions)
    meter.stop()
    return {"shapes": shapes, "match": meter.stages["match"], "matches": len(correspondence),
            "wall": time.perf_counter() - start_wall, "cpu": time.process_time() - start_cpu}


def child_spectral(task: dict) -> dict:
    """HKS or WKS at darcyan's feature points: eigendecomposition per shape, descriptors, match."""
    from darcyan.eval import baselines
    from darcyan.geometry import spectral
    from darcyan.method.matching import match_descriptors

    start_wall, start_cpu = time.perf_counter(), time.process_time()
    meter = StageMeter()
    descriptors = []
    stages: dict[str, dict] = {}
    for path, features in zip(task["files"], task["features"]):
        mesh = _prepared(path, meter)
        meter.start("spectrum")
        spectrum = spectral.laplace_beltrami_spectrum(mesh)
        meter.start("descriptors")
        descriptors.append(baselines.spectral_descriptors(task["method"], spectrum, _features_in(mesh, features)))
        meter.stop()
        _accumulate(stages, meter.stages)
        meter = StageMeter()
    meter.start("match")
    match_descriptors(descriptors[0], descriptors[1], "nearest")
    meter.stop()
    _accumulate(stages, meter.stages)
    return {"stages": stages, "wall": time.perf_counter() - start_wall, "cpu": time.process_time() - start_cpu}


def child_pyfm(task: dict) -> dict:
    """pyfmaps' dense pipeline: its eigenpairs, WKS, functional map + ZoomOut, point map."""
    from darcyan.dense import pyfm
    from darcyan.eval import baselines

    start_wall, start_cpu = time.perf_counter(), time.process_time()
    meter = StageMeter()
    meshes, spectra = [], []
    stages: dict[str, dict] = {}
    for path in task["files"]:
        mesh = _prepared(path, meter)
        meter.start("spectrum")
        spectra.append(pyfm.pyfm_spectrum(mesh, pyfm.README_PIPELINE.spectrum))
        meter.stop()
        meshes.append(mesh)
        _accumulate(stages, meter.stages)
        meter = StageMeter()
    meter.start("functional map + ZoomOut + point map")
    point_map = baselines.pyfm_point_map(meshes[0], meshes[1], spectra[0], spectra[1])
    meter.stop()
    _accumulate(stages, meter.stages)
    return {"stages": stages, "n_mapped": int(len(point_map)),
            "wall": time.perf_counter() - start_wall, "cpu": time.process_time() - start_cpu}


def _describe_file(path: str):
    """describe_shape in a worker process; what cannot be pickled back (solvers) is dropped."""
    import dataclasses
    import pickle

    from darcyan.method.pipeline import describe_shape

    description = describe_shape(path)
    dropped = {}
    for f in dataclasses.fields(description):
        try:
            pickle.dumps(getattr(description, f.name))
        except Exception:
            dropped[f.name] = None
    return dataclasses.replace(description, **dropped)


def child_parallel(task: dict) -> dict:
    """The two shapes described in two worker processes at once, then matched (what a
    two-process ``match`` would cost on this machine)."""
    from concurrent.futures import ProcessPoolExecutor

    from darcyan.method.pipeline import match_shapes

    start = time.perf_counter()
    with ProcessPoolExecutor(max_workers=2) as pool:
        descriptions = list(pool.map(_describe_file, task["files"]))
    match_shapes(*descriptions)
    return {"wall": time.perf_counter() - start}


def child_warm(task: dict) -> dict:
    """In-process: both shapes from a filled ShapeCache, then matched (imports excluded)."""
    from darcyan.io.cache import ShapeCache
    from darcyan.method.pipeline import describe_shape, match_shapes

    cache = ShapeCache(task["cache"])
    start_wall, start_cpu = time.perf_counter(), time.process_time()
    shapes = [describe_shape(path, cache=cache) for path in task["files"]]
    hits = sum("cache" in s.timings for s in shapes)
    match_shapes(*shapes)
    return {"wall": time.perf_counter() - start_wall, "cpu": time.process_time() - start_cpu, "hits": hits}


def child_describe(task: dict) -> dict:
    """One shape (a file or the synthetic figure) described stage by stage."""
    from darcyan.geometry import synthetic
    from darcyan.method.pipeline import analyze_mesh

    kind, _, value = task["source"].partition(":")
    mesh = synthetic.figure(0, int(value)) if kind == "figure" else _load(value)
    meter = StageMeter()
    start_wall, start_cpu = time.perf_counter(), time.process_time()
    analyze_mesh(mesh, progress=meter.start)
    meter.stop()
    return {"n_vertices": mesh.n_vertices, "stages": meter.stages,
            "wall": time.perf_counter() - start_wall, "cpu": time.process_time() - start_cpu}


def child_profile(task: dict) -> dict:
    """cProfile, timed by CPU time (so other processes' load does not skew the shares), over
    describing and matching the pair; hot spots by self time and darcyan functions by inclusive
    time. Compiled functions (fast marching, the tracer, libigl's AABB tree) appear by name."""
    import cProfile
    import pstats

    from darcyan.method.pipeline import analyze_mesh, match_shapes

    meshes = [_load(path) for path in task["files"]]
    profiler = cProfile.Profile(time.process_time)
    profiler.enable()
    match_shapes(*[analyze_mesh(mesh) for mesh in meshes])
    profiler.disable()
    stats = pstats.Stats(profiler)
    if task.get("text"):
        with open(task["text"], "w") as fh:
            pstats.Stats(profiler, stream=fh).sort_stats("cumulative").print_stats(60)
    rows = []
    for (file, line, function), (_, calls, self_time, inclusive, _) in stats.stats.items():
        where = "/".join(Path(file).parts[-2:]) if file.startswith(("/", ".")) else file
        name = function.rsplit(".", 1)[-1] if "pybind11" in function else function
        rows.append({"name": f"{name} ({where}:{line})", "calls": calls, "self": self_time,
                     "inclusive": inclusive, "darcyan": "/darcyan/" in file})
    total = max(r["inclusive"] for r in rows)
    by_self = sorted(rows, key=lambda r: -r["self"])[:HOT_SPOTS]
    by_inclusive = sorted((r for r in rows if r["darcyan"]), key=lambda r: -r["inclusive"])[:HOT_SPOTS]
    return {"total": total, "self": by_self, "inclusive": by_inclusive}


def _accumulate(total: dict, stages: dict) -> None:
    for name, s in stages.items():
        t = total.setdefault(name, {"wall": 0.0, "cpu": 0.0, "peak_mb": 0.0})
        t["wall"] += s["wall"]
        t["cpu"] += s["cpu"]
        t["peak_mb"] = max(t["peak_mb"], s["peak_mb"])


CHILDREN = {"pipeline": child_pipeline, "spectral": child_spectral, "pyfm": child_pyfm,
            "parallel": child_parallel, "warm": child_warm, "describe": child_describe,
            "profile": child_profile}
RESULT_MARK = "SPEED-RESULT "
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


# ------------------------------------------------------------------------------------------------
# Running children and commands from the parent


def run_process(argv: list[str], env: dict | None = None) -> dict:
    """Run ``argv`` to completion: wall time, CPU time (user + system) and peak RSS from wait4."""
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        start = time.perf_counter()
        proc = subprocess.Popen(argv, stdout=out, stderr=err, env=env)
        _, status, usage = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - start
        proc.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        stdout, stderr = out.read().decode(errors="replace"), err.read().decode(errors="replace")
    return {"wall": wall, "cpu": usage.ru_utime + usage.ru_stime, "peak_mb": usage.ru_maxrss / 1024.0,
            "code": proc.returncode, "stdout": stdout, "stderr": stderr}


def run_child(task: dict) -> dict:
    """Run one measurement in a fresh interpreter and return its result (plus whole-process figures)."""
    done = run_process([sys.executable, str(Path(__file__).resolve()), "--child", json.dumps(task)],
                       env=_env(task.get("cache")))
    lines = [line for line in done["stdout"].splitlines() if line.startswith(RESULT_MARK)]
    if done["code"] != 0 or not lines:
        tail = done["stderr"].strip().splitlines()[-3:]
        return {"error": f"child {task['task']} failed (exit {done['code']}): {' | '.join(tail)}"}
    result = json.loads(lines[-1][len(RESULT_MARK):])
    result["process"] = {k: done[k] for k in ("wall", "cpu", "peak_mb")}
    return result


COMPILE_DARCYAN = "import compileall, os, darcyan; compileall.compile_dir(os.path.dirname(darcyan.__file__), quiet=1)"


def _env(cache: str | None = None) -> dict:
    # Bytecode as an installed package has it: with PYTHONDONTWRITEBYTECODE set (some sandboxes
    # and containers set it), every run compiles darcyan's modules from source, about 60 ms of a
    # warm match that no pip-installed copy pays.
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["DARCYAN_CACHE"] = cache or tempfile.mkdtemp(prefix="darcyan-speed-cache-")
    return env


def load_average() -> str:
    try:
        return "load average %.2f %.2f %.2f" % os.getloadavg()
    except OSError:
        return "load average unknown"


# ------------------------------------------------------------------------------------------------
# The report


def fmt(x: float, digits: int = 2) -> str:
    return f"{x:.{digits}f}" if x is not None else "-"


def stage_table(results: dict) -> str:
    """Per stage and pair: wall s, CPU s, peak RSS MB (stages summed over the two shapes)."""
    labels = list(results)
    order: list[str] = []
    per_pair = {}
    for label, r in results.items():
        totals: dict[str, dict] = {}
        for shape in r["shapes"]:
            _accumulate(totals, shape["stages"])
            order += [s for s in shape["stages"] if s not in order]
        _accumulate(totals, {"match": r["match"]})
        per_pair[label] = totals
    order.append("match")
    head = "| stage | " + " | ".join(f"{lab} wall s | {lab} CPU s | {lab} peak MB" for lab in labels) + " |"
    rows = [head, "|" + "---|" * (1 + 3 * len(labels))]
    for stage in order:
        cells = []
        for label in labels:
            s = per_pair[label].get(stage)
            cells += [fmt(s["wall"]), fmt(s["cpu"]), fmt(s["peak_mb"], 0)] if s else ["-"] * 3
        rows.append(f"| {STAGE_NAMES.get(stage, stage)} | " + " | ".join(cells) + " |")
    cells = []
    for label in labels:
        r = results[label]
        cells += [f"**{fmt(r['wall'])}**", f"**{fmt(r['cpu'])}**", f"**{fmt(r['process']['peak_mb'], 0)}**"]
    rows.append("| total in-process (both shapes + match) | " + " | ".join(cells) + " |")
    return "\n".join(rows)


STAGE_NAMES = {"descriptors": "grids + descriptors", "agd": "AGD"}


def fit_exponent(sizes, times) -> float | None:
    import numpy as np

    sizes, times = np.asarray(sizes, float), np.asarray(times, float)
    ok = (sizes > 0) & (times > 0)
    if ok.sum() < 2:
        return None
    return float(np.polyfit(np.log(sizes[ok]), np.log(times[ok]), 1)[0])


def scaling_table(rows: list[dict]) -> str:
    stages: list[str] = []
    for r in rows:
        stages += [s for s in r["stages"] if s not in stages]
    head = "| mesh | vertices | total wall s | total CPU s | peak MB | " + " | ".join(
        f"{STAGE_NAMES.get(s, s)} CPU s" for s in stages) + " |"
    lines = [head, "|" + "---|" * (5 + len(stages))]
    for r in rows:
        peak = max(s["peak_mb"] for s in r["stages"].values())
        cells = [fmt(r["stages"][s]["cpu"], 3) if s in r["stages"] else "-" for s in stages]
        lines.append(f"| {r['source']} | {r['n_vertices']:,} | {fmt(r['wall'])} | {fmt(r['cpu'])} | {fmt(peak, 0)} | "
                     + " | ".join(cells) + " |")
    for name, subset in (("figure (subdivisions)", [r for r in rows if r["source"].startswith("figure")]),
                         ("TOSCA meshes", [r for r in rows if not r["source"].startswith("figure")]),
                         ("all", rows)):
        if len(subset) < 2:
            continue
        sizes = [r["n_vertices"] for r in subset]
        total = fit_exponent(sizes, [r["cpu"] for r in subset])
        per_stage = [fit_exponent(sizes, [r["stages"].get(s, {}).get("cpu", 0) for r in subset]) for s in stages]
        lines.append(f"| exponent a, {name} | | | **{fmt(total)}** | | "
                     + " | ".join(fmt(a) if a is not None else "-" for a in per_stage) + " |")
    return "\n".join(lines)


# A neighbour that keeps one core busy (pure Python: it holds no BLAS pool of its own).
BUSY_NEIGHBOUR = "import time\nend = time.time() + 3600\nwhile time.time() < end: pass\n"
THREAD_SETTINGS = {
    "default": ([], {}),
    "OMP_NUM_THREADS=1": ([], {name: "1" for name in THREAD_VARIABLES}),
    "--threads 0 (libraries' pools)": (["--threads", "0"], {}),
}


def threads_study(repeat: int) -> int:
    """Wall time of `darcyan match` with each of THREAD_SETTINGS, idle and beside a busy
    neighbour (best of ``repeat``): the default must never be much slower than one thread."""
    def say(*text):
        print(*text, flush=True)

    big, small = [str(DATA / p) for p in PAIRS["52k"]], [str(DATA / p) for p in PAIRS["5k"]]
    cache = tempfile.mkdtemp(prefix="darcyan-speed-cache-")
    base_env = {k: v for k, v in _env(cache).items() if k not in THREAD_VARIABLES}
    run_process([sys.executable, "-m", "darcyan", "match", *big, "-q"], base_env)  # fill the cache
    run_process([sys.executable, "-m", "darcyan", "match", *small, "-q"], base_env)
    jobs = {"warm match, 52k": ["match", *big, "-q"], "cold match, 52k": ["match", *big, "--no-cache", "-q"],
            "--dense, 5k (cached descriptions)": ["match", *small, "--dense", "-o", os.devnull, "-q"]}
    say(f"## Threads: `darcyan match` idle and beside a busy neighbour ({os.cpu_count()} CPUs)\n")
    say("| job | threads | idle s | busy neighbour s |\n|---|---|---:|---:|")
    for job, argv in jobs.items():
        for name, (extra, env) in THREAD_SETTINGS.items():
            times = []
            for busy in (False, True):
                neighbour = subprocess.Popen([sys.executable, "-c", BUSY_NEIGHBOUR]) if busy else None
                try:
                    time.sleep(0.5 if busy else 0.0)
                    runs = [run_process([sys.executable, "-m", "darcyan", *argv, *extra], {**base_env, **env})
                            for _ in range(repeat)]
                finally:
                    if neighbour is not None:
                        neighbour.kill()
                        neighbour.wait()
                failed = [r for r in runs if r["code"] != 0]
                times.append("failed" if failed else fmt(min(r["wall"] for r in runs)))
            say(f"| {job} | {name} | {times[0]} | {times[1]} |")
    say("")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--child", help=argparse.SUPPRESS)
    parser.add_argument("--sizes", nargs="+", choices=list(PAIRS), default=list(PAIRS), help="TOSCA pairs (default all)")
    parser.add_argument("--peers", nargs="*", choices=PEERS, default=list(PEERS), help="peers to run (default all)")
    parser.add_argument("--no-peers", action="store_true", help="skip the peers")
    parser.add_argument("--no-scaling", action="store_true", help="skip the timing across sizes")
    parser.add_argument("--no-profile", action="store_true", help="skip the profile of the largest pair")
    parser.add_argument("--profile-text", help="also write the profiler's full report (by cumulative time) here")
    parser.add_argument("--repeat", type=int, default=1, help="runs of each command-line measurement; the fastest is kept")
    parser.add_argument("--json", help="write the raw measurements to this file")
    parser.add_argument("--threads-study", action="store_true",
                        help="only the threads study: `darcyan match` (warm 52k, cold 52k, --dense 5k) with its "
                             "default threads, with OMP_NUM_THREADS=1 and with --threads 0 (the libraries' own "
                             "pools), on an idle machine and beside a busy neighbour process")
    parser.add_argument("--threads", type=int, help="BLAS/OpenMP threads of every measured process "
                        "(OPENBLAS/OMP/MKL_NUM_THREADS; default: the environment's). On a shared machine "
                        "1 avoids oversubscription, which slows the eigensolvers of the peers several times")
    args = parser.parse_args(argv)

    if args.threads:
        for name in THREAD_VARIABLES:
            os.environ[name] = str(args.threads)
    if args.child:
        task = json.loads(args.child)
        result = CHILDREN[task["task"]](task)
        print(RESULT_MARK + json.dumps(result), flush=True)
        return 0
    if args.threads_study:
        return threads_study(args.repeat)

    missing = [p for pair in args.sizes for p in PAIRS[pair] if not (DATA / p).exists()]
    if missing:
        print(f"speed.py: data not found: {DATA / missing[0]} (set DARCYAN_DATA)", file=sys.stderr)
        return 2
    raw: dict = {"machine": {"cpus": os.cpu_count(), "python": sys.version.split()[0]}}
    say = lambda *a: print(*a, flush=True)  # noqa: E731
    threads = os.environ.get("OPENBLAS_NUM_THREADS", "default")
    say(f"# darcyan speed and memory ({os.cpu_count()} CPUs, BLAS threads {threads}, "
        f"Python {sys.version.split()[0]}, {load_average()})\n")

    # 1. Stages, in-process.
    stages = {}
    for label in args.sizes:
        files = [str(DATA / p) for p in PAIRS[label]]
        stages[label] = run_child({"task": "pipeline", "files": files})
        if "error" in stages[label]:
            say(f"{label}: {stages[label]['error']}")
            return 1
    raw["stages"] = stages
    say("## Stages (in-process, both shapes of each pair; peak = process RSS high-water mark during the stage)\n")
    say("Pairs: " + ", ".join(f"{lab} = {' / '.join(Path(p).stem for p in PAIRS[lab])} "
                              f"({stages[lab]['shapes'][0]['n_vertices']:,} vertices)" for lab in args.sizes) + "\n")
    say(stage_table(stages) + "\n")

    # 2. End to end on the command line: cold, cache filled, warm; and the two-process variant.
    say(f"## `darcyan match` end to end (separate process, imports included; {load_average()})\n")
    say("| pair | run | wall s | CPU s | peak RSS MB |\n|---|---|---|---|---|")
    raw["cli"] = {}
    run_process([sys.executable, "-c", COMPILE_DARCYAN], _env())  # its bytecode written once, before any timing
    for label in args.sizes:
        files = [str(DATA / p) for p in PAIRS[label]]
        cache = tempfile.mkdtemp(prefix="darcyan-speed-cache-")
        runs = {}
        cold = [run_process([sys.executable, "-m", "darcyan", "match", *files, "--no-cache"], _env()) for _ in range(args.repeat)]
        runs["cold (--no-cache)"] = min(cold, key=lambda r: r["wall"])
        runs["first, filling the cache"] = run_process([sys.executable, "-m", "darcyan", "match", *files], _env(cache))
        warm = [run_process([sys.executable, "-m", "darcyan", "match", *files], _env(cache)) for _ in range(args.repeat)]
        runs["second, warm cache"] = min(warm, key=lambda r: r["wall"])
        runs["import only (`python -c 'import darcyan.cli, darcyan.method.pipeline'`)"] = run_process(
            [sys.executable, "-c", "import darcyan.cli, darcyan.method.pipeline"], _env())
        in_process = run_child({"task": "warm", "files": files, "cache": cache})
        parallel = run_child({"task": "parallel", "files": files})
        for name, r in runs.items():
            if r.get("code", 0) != 0:
                say(f"| {label} | {name} | failed: {r['stderr'].strip().splitlines()[-1:]} | | |")
                continue
            say(f"| {label} | {name} | {fmt(r['wall'])} | {fmt(r['cpu'])} | {fmt(r['peak_mb'], 0)} |")
        for r in (in_process, parallel):
            if "error" in r:
                say(f"| {label} | {r['error']} | | | |")
        if "error" not in in_process:
            say(f"| {label} | warm cache, in-process (describe x2 from cache + match; {in_process['hits']}/2 hits) "
                f"| {fmt(in_process['wall'], 3)} | {fmt(in_process['cpu'], 3)} | - |")
        if "error" not in parallel:
            say(f"| {label} | experiment: the two shapes described in 2 worker processes, in-process "
                f"| {fmt(parallel['wall'])} | - | - |")
        raw["cli"][label] = {"runs": {k: {m: v[m] for m in ("wall", "cpu", "peak_mb")} for k, v in runs.items()},
                             "warm_in_process": in_process, "parallel": parallel}
    say("")
    if "52k" in raw["cli"]:
        runs = raw["cli"]["52k"]["runs"]
        cold, warm = runs["cold (--no-cache)"], runs["second, warm cache"]
        verdict = lambda ok: "met" if ok else "NOT met"  # noqa: E731
        say("Goals (52k pair, wall time as measured): "
            f"end to end < {GOAL_PAIR_ISSUE_2:g} s (issue 2): {verdict(cold['wall'] < GOAL_PAIR_ISSUE_2)} ({fmt(cold['wall'])} s); "
            f"< {GOAL_PAIR_ISSUE_5:g} s (issue 5): {verdict(cold['wall'] < GOAL_PAIR_ISSUE_5)}; "
            f"warm second match < {GOAL_WARM:g} s: {verdict(warm['wall'] < GOAL_WARM)} ({fmt(warm['wall'])} s, "
            f"in-process {fmt(raw['cli']['52k']['warm_in_process'].get('wall'), 3)} s); "
            f"peak memory < {GOAL_MEMORY_MB / 1024:g} GB: {verdict(cold['peak_mb'] < GOAL_MEMORY_MB)} "
            f"({fmt(cold['peak_mb'], 0)} MB)\n")

    # 3. Peers at the same feature points.
    peers = [] if args.no_peers else args.peers
    if peers:
        say(f"## Peers on the same pairs ({load_average()})\n")
        say("In-process, imports excluded; each peer includes loading and preparing both meshes. "
            "HKS/WKS are evaluated at darcyan's feature points; pyfm maps every vertex.\n")
        say("| pair | method | wall s | CPU s | peak RSS MB | wall ratio peer/darcyan | CPU ratio | where the time goes |")
        say("|---|---|---|---|---|---|---|---|")
        raw["peers"] = {}
        for label in args.sizes:
            files = [str(DATA / p) for p in PAIRS[label]]
            base = stages[label]
            peak = fmt(base['process']['peak_mb'], 0)
            say(f"| {label} | darcyan | {fmt(base['wall'])} | {fmt(base['cpu'])} | {peak} | 1 | 1 | see the stage table |")
            raw["peers"][label] = {}
            for peer in peers:
                if peer == "pyfm":
                    r = run_child({"task": "pyfm", "files": files})
                else:
                    r = run_child({"task": "spectral", "method": peer, "files": files,
                                   "features": [s["features"] for s in base["shapes"]]})
                raw["peers"][label][peer] = r
                if "error" in r:
                    say(f"| {label} | {peer} | {r['error']} | | | | | |")
                    continue
                where = ", ".join(f"{name} {fmt(s['wall'], 1)} s" for name, s in r["stages"].items())
                say(f"| {label} | {peer} | {fmt(r['wall'])} | {fmt(r['cpu'])} | {fmt(r['process']['peak_mb'], 0)} | "
                    f"{fmt(r['wall'] / base['wall'], 1)} | {fmt(r['cpu'] / base['cpu'], 1)} | {where} |")
        say("")

    # 4. Cost across sizes.
    if not args.no_scaling:
        say(f"## Cost across sizes (one shape described, in-process; {load_average()})\n")
        rows = []
        sources = [f"figure:{s}" for s in FIGURE_SUBDIVISIONS] + [f"file:{DATA / p}" for p in SCALING_TOSCA if (DATA / p).exists()]
        for source in sources:
            r = run_child({"task": "describe", "source": source})
            if "error" in r:
                say(f"{source}: {r['error']}")
                continue
            kind, _, value = source.partition(":")
            r["source"] = f"figure, subdivisions {value}" if kind == "figure" else Path(value).parent.name + "/" + Path(value).stem
            rows.append(r)
        raw["scaling"] = rows
        say(scaling_table(rows) + "\n")
        say("a: least-squares slope of log(CPU time) against log(vertices); V log V over this range fits a ~ 1.1.\n")

    # 5. Profile of the largest pair.
    if not args.no_profile:
        label = args.sizes[-1]
        files = [str(DATA / p) for p in PAIRS[label]]
        r = run_child({"task": "profile", "files": files, "text": args.profile_text})
        raw["profile"] = r
        say(f"## Profile of the {label} pair (cProfile by CPU time, both shapes described and matched; {load_average()})\n")
        if "error" in r:
            say(r["error"])
        else:
            say(f"CPU time {fmt(r['total'])} s under the profiler.\n")
            say("| hot spot (self CPU time) | calls | s | share |\n|---|---|---|---|")
            for row in r["self"]:
                say(f"| `{row['name']}` | {row['calls']} | {fmt(row['self'])} | {100 * row['self'] / r['total']:.0f}% |")
            say("\n| darcyan function (inclusive CPU time) | calls | s | share |\n|---|---|---|---|")
            for row in r["inclusive"]:
                say(f"| `{row['name']}` | {row['calls']} | {fmt(row['inclusive'])} | "
                    f"{100 * row['inclusive'] / r['total']:.0f}% |")
            say("")
    if args.json:
        Path(args.json).write_text(json.dumps(raw, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
