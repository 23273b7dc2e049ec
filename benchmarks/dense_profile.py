"""Where a cold match spends its time and memory, stage by stage: the profile that every speed
claim of the dense map cites (issue 43).

Usage (from the repository root; the data at ../shared/data or $DARCYAN_DATA)::

    python benchmarks/dense_profile.py                    # 5k, 52k and 210k pairs, dense and sparse
    python benchmarks/dense_profile.py --sizes 5k 52k --repeat 3
    python benchmarks/dense_profile.py --json profile.json

Each measurement is a fresh child process (``python dense_profile.py --child ...``), cold: no
cache, nothing imported before it starts. The child times what ``darcyan match A B [--dense]``
does through the library's front door (:func:`darcyan.correspond`, which the command calls):

* ``start``: the interpreter and ``import darcyan`` (before the child's clock: measured as the
  whole process's wall time minus the stages);
* ``describe``: both shapes prepared and described (one in the child, the other in a worker
  process beside it), with a dense map each shape's basis and signature too;
* ``match``: the sparse matching (and a verification when one is made);
* the dense map's own stages, as its progress names them: ``basis``, ``landmarks`` (the seeds
  scored by short ZoomOuts), ``zoomout`` (the chosen seed's ZoomOut and the read-out of every
  vertex), ``alignment``;
* ``write``: the CSV.

Peak memory per stage is the resident set size's high-water mark of the child (VmHWM, reset
before each stage through ``/proc/self/clear_refs``; the worker's own is not counted, it is
smaller). Whole: the child's wall and CPU time (``wait4``) and the largest of its stages' peaks
(the resets reset ``ru_maxrss`` too). Medians over
``--repeat`` runs. The 210k pair is TOSCA's david0 and david1 subdivided once
(``trimesh.remesh.subdivide``, 210,160 vertices each), written to ``--work`` on first use.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from speed import DATA, _peak_mb, _reset_peak  # benchmarks/speed.py: the data folder, the high-water mark

# label -> (source, target): relative to DATA, or a subdivided copy (see subdivided_pair)
PAIRS = {
    "5k": ("faust-5k/tr_reg_000.off", "faust-5k/tr_reg_001.off"),
    "5k-tosca": ("tosca-5k/cat0.off", "tosca-5k/cat1.off"),
    "52k": ("tosca-hires/david0.off", "tosca-hires/david1.off"),
    "210k": ("subdivided:tosca-hires/david0.off", "subdivided:tosca-hires/david1.off"),
}
STAGES = ("describe", "match", "basis", "landmarks", "zoomout", "alignment", "write")
MB = 1024.0 * 1024.0


def child(source: str, target: str, dense: bool, output: str) -> dict:
    """In the child: one cold match through the front door, its stages timed and measured."""
    import darcyan

    begun = time.perf_counter()
    stages: dict = {}
    current = {"name": "describe", "wall": time.perf_counter(), "cpu": time.process_time()}
    _reset_peak()

    def enter(name: str) -> None:
        stages[current["name"]] = {"wall": time.perf_counter() - current["wall"],
                                   "cpu": time.process_time() - current["cpu"], "peak_mb": _peak_mb()}
        _reset_peak()
        current.update(name=name, wall=time.perf_counter(), cpu=time.process_time())

    def progress(line: str) -> None:
        if line.startswith("described"):
            enter("match")
        elif line.startswith("dense map: ") and line[len("dense map: "):] in STAGES:
            enter(line[len("dense map: "):])

    result = darcyan.correspond(source, target, dense=dense, cache=False, progress=progress)
    enter("write")
    result.to_csv(output)
    enter("end")
    return {"stages": stages, "imports": begun - _started_at(), "in_process": time.perf_counter() - begun}


def _started_at() -> float:
    """perf_counter's reading at this process's start (from its age in /proc)."""
    ticks = os.sysconf("SC_CLK_TCK")
    with open("/proc/self/stat") as fh:
        start_ticks = int(fh.read().rsplit(")", 1)[1].split()[19])
    with open("/proc/uptime") as fh:
        uptime = float(fh.read().split()[0])
    return time.perf_counter() - (uptime - start_ticks / ticks)


def subdivided_pair(work: Path, relative: str) -> str:
    """The mesh ``DATA/relative`` subdivided once (each triangle into four), made on first use."""
    import trimesh

    out = work / ("subdivided-" + relative.replace("/", "-"))
    if not out.exists():
        mesh = trimesh.load(DATA / relative, process=False)
        vertices, faces = trimesh.remesh.subdivide(mesh.vertices, mesh.faces)
        out.parent.mkdir(parents=True, exist_ok=True)
        trimesh.Trimesh(vertices, faces, process=False).export(out)
    return str(out)


def resolve(path: str, work: Path) -> str:
    return subdivided_pair(work, path.split(":", 1)[1]) if path.startswith("subdivided:") else str(DATA / path)


def measure(source: str, target: str, dense: bool) -> dict:
    """One child process: its report, and its whole wall time, CPU time and peak memory."""
    with tempfile.TemporaryDirectory() as folder:
        report = Path(folder) / "report.json"
        argv = [sys.executable, __file__, "--child", source, target, "--report", str(report)]
        argv += ["--dense"] if dense else []
        start = time.perf_counter()
        process = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        _, status, usage = os.wait4(process.pid, 0)
        wall = time.perf_counter() - start
        if os.waitstatus_to_exitcode(status) != 0:
            raise SystemExit(f"dense_profile: the child failed on {source} -> {target}: {process.stderr.read()[-2000:]}")
        out = json.loads(report.read_text())
    # The stages' resets of the high-water mark reset ru_maxrss too: the whole peak is theirs.
    peaks = [stage["peak_mb"] for stage in out["stages"].values()]
    out.update(wall=wall, cpu=usage.ru_utime + usage.ru_stime, peak_mb=max([usage.ru_maxrss / 1024.0, *peaks]))
    return out


def median_run(runs: list) -> dict:
    """Per stage and whole: the median of each figure over the runs."""
    names = [name for name in runs[0]["stages"] if name != "end"]
    stages = {name: {key: statistics.median(run["stages"][name][key] for run in runs if name in run["stages"])
                     for key in ("wall", "cpu", "peak_mb")} for name in names}
    whole = {key: statistics.median(run[key] for run in runs) for key in ("wall", "cpu", "peak_mb", "imports")}
    return {"stages": stages, **whole}


def table(results: dict) -> str:
    """A markdown table: a column per pair and mode, a row per stage (wall s / peak MB)."""
    columns = list(results)
    names = []
    for result in results.values():
        names += [name for name in result["stages"] if name not in names]
    lines = ["| stage | " + " | ".join(columns) + " |", "| --- |" + " ---: |" * len(columns)]
    lines.append("| start (interpreter, imports) | " + " | ".join(f"{results[c]['imports']:.2f} s" for c in columns) + " |")
    for name in names:
        cells = []
        for c in columns:
            stage = results[c]["stages"].get(name)
            cells.append("" if stage is None else f"{stage['wall']:.2f} s / {stage['peak_mb']:.0f} MB")
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    lines.append("| **whole process** (wall / CPU / peak) | " + " | ".join(
        f"**{results[c]['wall']:.2f} s** / {results[c]['cpu']:.2f} s / {results[c]['peak_mb']:.0f} MB" for c in columns) + " |")
    return "\n".join(lines)


def main(argv: list | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", nargs="+", default=["5k", "5k-tosca", "52k", "210k"], choices=list(PAIRS))
    parser.add_argument("--modes", nargs="+", default=["dense", "sparse"], choices=["dense", "sparse"])
    parser.add_argument("--repeat", type=int, default=1, help="runs per measurement (medians)")
    parser.add_argument("--work", type=Path, default=Path(tempfile.gettempdir()) / "darcyan-profile",
                        help="where the subdivided 210k pair is kept")
    parser.add_argument("--json", type=Path, help="also write the raw measurements here")
    parser.add_argument("--child", nargs=2, metavar=("SOURCE", "TARGET"), help=argparse.SUPPRESS)
    parser.add_argument("--dense", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--report", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        with tempfile.TemporaryDirectory() as folder:
            report = child(*args.child, args.dense, str(Path(folder) / "map.csv"))
        args.report.write_text(json.dumps(report))
        return 0
    results, raw = {}, {}
    for size in args.sizes:
        source, target = (resolve(path, args.work) for path in PAIRS[size])
        for mode in args.modes:
            runs = []
            for i in range(args.repeat):
                print(f"dense_profile: {size} {mode} run {i + 1}/{args.repeat}", file=sys.stderr, flush=True)
                runs.append(measure(source, target, mode == "dense"))
            results[f"{size} {mode}"], raw[f"{size} {mode}"] = median_run(runs), runs
    with open("/proc/loadavg") as fh:
        load = " ".join(fh.read().split()[:3])
    print(f"Cold `darcyan match A B [--dense] --no-cache -o map.csv` through darcyan.correspond, medians of "
          f"{args.repeat} run(s), {os.cpu_count()} cores, load average {load}; per stage wall time / peak RSS of "
          f"the process during it (MiB).\n")
    print(table(results))
    if args.json:
        args.json.write_text(json.dumps(raw, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
