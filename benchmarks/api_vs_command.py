"""Is the library as fast as the command beside a busy neighbour? (the library owns its threads)

Times, as whole processes run in turn (API, command, API, ...), a cold dense match of one pair
through ``darcyan.correspond`` in a plain ``python -c`` (the default environment: no thread
variables set) and through ``darcyan match --dense``, while a neighbour process keeps the BLAS
thread pools of every core busy (a large matrix product in a loop, the libraries' own threads).
Prints a table of medians and the ratio API / command, pair by pair.

    python benchmarks/api_vs_command.py ../shared/data/tosca-hires/cat0.off ../shared/data/tosca-hires/cat1.off --runs 3
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time

NEIGHBOUR = "import numpy as np\na = np.random.rand(1500, 1500)\nwhile True:\n    a @ a\n"


def timed(command: list, env: dict) -> float:
    start = time.perf_counter()
    subprocess.run(command, check=True, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - start


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("source")
    parser.add_argument("target")
    parser.add_argument("--runs", type=int, default=3, help="pairs of runs (default %(default)s)")
    parser.add_argument("--idle", action="store_true", help="no busy neighbour")
    args = parser.parse_args(argv)
    env = {k: v for k, v in os.environ.items() if k not in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS",
                                                             "MKL_NUM_THREADS", "DARCYAN_THREADS")}
    out = tempfile.mkdtemp()
    api = [sys.executable, "-c", f"import darcyan; darcyan.correspond({args.source!r}, {args.target!r}, dense=True, "
                                 f"cache=False).to_csv({os.path.join(out, 'api.csv')!r})"]
    command = [sys.executable, "-m", "darcyan", "match", args.source, args.target, "--dense", "--no-cache", "-q",
               "-o", os.path.join(out, "command.csv")]
    neighbour = None if args.idle else subprocess.Popen([sys.executable, "-c", NEIGHBOUR], env=env)
    try:
        timed(command, env)  # a warm-up: files in the page cache, modules compiled
        times = {"api": [], "command": []}
        for _ in range(args.runs):
            times["api"].append(timed(api, env))
            times["command"].append(timed(command, env))
    finally:
        if neighbour is not None:
            neighbour.kill()
    same = open(os.path.join(out, "api.csv"), "rb").read() == open(os.path.join(out, "command.csv"), "rb").read()
    ratios = sorted(a / c for a, c in zip(times["api"], times["command"]))
    median = lambda values: sorted(values)[len(values) // 2]  # noqa: E731
    print("| pair | neighbour | API (median s) | command (median s) | ratio API / command (median, min-max) | same map |")
    print("| --- | --- | ---: | ---: | --- | --- |")
    print(f"| {os.path.basename(args.source)} -> {os.path.basename(args.target)} | {'idle' if args.idle else 'busy'} "
          f"| {median(times['api']):.2f} | {median(times['command']):.2f} | {median(ratios):.2f} "
          f"({ratios[0]:.2f}-{ratios[-1]:.2f}) | {'yes' if same else 'no'} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
