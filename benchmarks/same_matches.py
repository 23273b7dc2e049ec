"""Does a change of the matching settings change any match? Every pair matched twice, compared.

A setting of the match stage (``config.mirror``, ``config.consistency``, ``max_match_distance``,
...) is changed to make matching faster or simpler; this counts the pairs whose matches (the
chosen one and every alternative the mirror test weighed) differ from the defaults'. Each shape
is described once (cached as ``darcyan match`` caches it), so the run costs the matching only.

    python benchmarks/same_matches.py ../shared/data/tosca-hires --change '{"mirror": {"target_points": 5000}}'
    python benchmarks/same_matches.py ../shared/data/tosca-5k --pairs ../shared/data/tosca-5k/test_pairs.txt \\
        --change '{"mirror": {"target_points": 5000}}'

Prints the number of pairs compared, those that differ (named), and the matching time of both.
Settings of the describe stage are refused: they would need two descriptions of every shape.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

from darcyan import DarcyanConfig
from darcyan.bench.datasets import default_pairs, discover_dataset, read_pairs
from darcyan.config import DESCRIBE, PREPARE
from darcyan.errors import DarcyanError
from darcyan.io.cache import ShapeCache
from darcyan.method.pipeline import describe_shapes, match_shapes


def _key(correspondence) -> tuple:
    """What a user of the matches sees, the alternatives included."""
    def one(c):
        return (tuple(c.source_vertex.tolist()), tuple(c.target_vertex.tolist()), tuple(c.distance.tolist()))
    return one(correspondence), tuple(one(a) for a in correspondence.alternatives)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("data", help="a dataset folder (see darcyan bench)")
    parser.add_argument("--pairs", help="pairs file (default: every ordered pair within each class)")
    parser.add_argument("--change", required=True, help="JSON of the settings to change, as in --config")
    parser.add_argument("--jobs", type=int, default=2, help="processes describing the shapes")
    args = parser.parse_args(argv)

    base = DarcyanConfig()
    try:
        changes = json.loads(args.change)
        if not isinstance(changes, dict):
            raise DarcyanError('--change: a JSON object of settings expected, e.g. {"mirror": {"samples": 400}}')
        changed = base.updated(changes, "--change")
        if changed.fingerprint(PREPARE, DESCRIBE) != base.fingerprint(PREPARE, DESCRIBE):
            raise DarcyanError("--change: only settings of the match stage can be compared this way")
        dataset = discover_dataset(args.data)
        pairs = read_pairs(args.pairs, dataset) if args.pairs else default_pairs(dataset)
        names = sorted({n for pair in pairs for n in pair})
        descriptions = dict(zip(names, describe_shapes([dataset.shapes[n] for n in names], base, False,
                                                       ShapeCache(), args.jobs)))
    except json.JSONDecodeError as exc:
        print(f"same_matches.py: error: --change is not JSON ({exc})", file=sys.stderr)
        return 2
    except DarcyanError as exc:  # config, dataset, pairs file or a mesh: each names what is wrong
        print(f"same_matches.py: error: {exc}", file=sys.stderr)
        return 2
    seconds = {"defaults": 0.0, "changed": 0.0}
    differ = []
    for a, b in pairs:
        keys = []
        for label, config in (("defaults", base), ("changed", changed)):
            start = time.perf_counter()
            keys.append(_key(match_shapes(descriptions[a], descriptions[b], config)))
            seconds[label] += time.perf_counter() - start
        if keys[0] != keys[1]:
            differ.append(f"{a}->{b}")
    print(f"{len(pairs)} pairs, {len(differ)} with other matches" + (f": {', '.join(differ)}" if differ else ""))
    print(f"matching time: defaults {seconds['defaults']:.1f} s, changed {seconds['changed']:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
