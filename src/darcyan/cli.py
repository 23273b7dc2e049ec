"""The ``darcyan`` command line: a thin shell over the Python API.

Every error the user can cause ends as one line ``darcyan: error: <input>: <problem>`` on stderr
and exit status 2; warnings (components left out, polygons split) are one line each.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import sys
import warnings
from pathlib import Path

import numpy as np

from ._version import __version__
from .config import MATCHING_MODES, DarcyanConfig, field_summary
from .errors import ConfigError, DarcyanError
from .geometry.mesh import MeshWarning
from .io.cache import ShapeCache

EXIT_USAGE = 2


# The DarcyanConfig fields that are command-line options (``--name-with-dashes``); their help is
# the first sentence of the field's own documentation (config.field_summary).
CONFIG_OPTIONS = ("levels", "radial_lines", "radius", "interpolation", "curvature_smoothing", "denoise_area_ratio",
                  "agd_sources", "agd_smoothing", "proxy_vertices", "extremity_radius", "min_agd_quantile", "tip_gain",
                  "tip_radius", "tip_agd_drop", "max_features", "max_match_distance")


def _add_config_options(parser: argparse.ArgumentParser) -> None:
    defaults = DarcyanConfig()
    group = parser.add_argument_group("method parameters (lengths in units of sqrt(surface area))")
    for name in CONFIG_OPTIONS:
        value = getattr(defaults, name)
        text = field_summary(DarcyanConfig, name).replace("%", "%%")
        group.add_argument(f"--{name.replace('_', '-')}", type=type(value), default=None,
                           help=f"{text} (default {value})")
    group.add_argument("--paper", action="store_true",
                       help="the paper's method as published: plain AGD maxima (--agd-smoothing 0 --extremity-radius "
                            "0.15 --tip-gain 0), no denoising and nearest-descriptor matching; options given beside it still apply")
    group.add_argument("--config", metavar="JSON",
                       help="a JSON file of settings to change (method parameters by name, sections such as "
                            "{\"mirror\": {\"samples\": 400}} in part; see darcyan.DarcyanConfig); options given beside it still apply")
    parser.add_argument("--repair", action="store_true",
                        help="also weld coincident boundary vertices (triangle soups, seams of textured files) instead "
                             "of refusing them")
    parser.add_argument("--strict", action="store_true",
                        help="refuse the ordinary imperfections that are otherwise repaired with a note (duplicate or "
                             "zero-area faces, unreferenced vertices, edges of three or more faces, inconsistent "
                             "orientation)")
    parser.add_argument("--no-cache", action="store_true", help="do not read or write the per-shape cache ($DARCYAN_CACHE)")
    parser.add_argument("--threads", type=int, default=None, metavar="N",
                        help="BLAS/OpenMP threads (default $DARCYAN_THREADS, else 1: the work is not BLAS-bound, and "
                             "more threads oversubscribe a busy machine; 0: the libraries' own default)")


def _config(args: argparse.Namespace) -> DarcyanConfig:
    """The defaults (or the paper's setup with ``--paper``), changed by the options given."""
    base = DarcyanConfig.paper() if getattr(args, "paper", False) else DarcyanConfig()
    if getattr(args, "config", None):
        try:
            base = base.updated(_read_json(args.config), args.config)
        except ConfigError as exc:  # name the file whose value it is
            message = str(exc)
            raise ConfigError(message if message.startswith(args.config) else f"{args.config}: {message}") from None
    values = {name: getattr(args, name) for name in CONFIG_OPTIONS if getattr(args, name, None) is not None}
    if getattr(args, "matching", None):
        values["matching"] = args.matching
    if getattr(args, "strict", False):
        if getattr(args, "repair", False):
            raise DarcyanError("--strict refuses what --repair mends: give one of them")
        values["repairing"] = dataclasses.replace(base.repairing, strict=True)
    return base.replace(**values)


def _read_json(path: str) -> dict:
    import json

    try:
        data = json.loads(Path(path).read_text())
    except FileNotFoundError:
        raise DarcyanError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise DarcyanError(f"{path}: not a JSON file ({exc})") from None
    if not isinstance(data, dict):
        raise DarcyanError(f"{path}: expected a JSON object of settings")
    return data


def _cache(args: argparse.Namespace) -> ShapeCache | None:
    return None if args.no_cache else ShapeCache()


def _write_text(text: str, output: str | None) -> None:
    if output is None or output == "-":
        sys.stdout.write(text)
        return
    from .api import write_file

    write_file(text, Path(output))


def _note_changes(shape) -> None:
    """One ``darcyan: note: <file>: <change>`` line on stderr per repair applied to the input."""
    for change in shape.changes:
        print(f"darcyan: note: {shape.name}: {change}", file=sys.stderr)


def cmd_match(args: argparse.Namespace) -> int:
    from .api import correspond
    from .method.pipeline import load_shape

    config = _config(args)
    if args.jobs < 1:
        raise DarcyanError(f"--jobs must be at least 1, got {args.jobs}")
    targets = args.targets
    several = len(targets) > 1
    if several and (args.plot or args.html or args.truth):
        raise DarcyanError("--plot, --html and --truth take one target: match the targets one by one")
    dense_config = None
    for option, value in (("--ensemble", args.ensemble), ("--sampling", args.sampling)):
        if value is not None and not args.dense:
            raise DarcyanError(f"{option} applies to --dense maps only")
    if args.dense:

        try:
            dense_config = config.dense_for() if args.ensemble is None else dataclasses.replace(config.dense_for(),
                                                                                          ensemble=args.ensemble)
        except ConfigError as exc:
            raise ConfigError(f"--ensemble: {exc}") from None
        if args.sampling is not None:
            dense_config = dataclasses.replace(dense_config, sampling=args.sampling)
    if several and args.dense:
        _dense_folder(args.output, targets)
    form = _output_format(args)
    if not (several and args.dense):
        _check_output(args.output, ("", ".csv", ".json", ".txt"))
    cache = _cache(args)
    if args.truth:
        from .eval.metrics import read_truth, score_matches

        read_truth(args.truth)  # a malformed spec or file fails before any computation
    _picture_dependencies(args)
    say = _progress(args)
    verify = True if args.verify else False if args.no_verify else "auto"
    result = correspond(args.source, targets, dense=args.dense, config=config, dense_config=dense_config,
                        cache=cache or False, verify=verify, repair=args.repair, jobs=args.jobs, progress=say)
    for description in result.descriptions:
        _note_changes(description)
    for pair in result:
        target, correspondence, dense = pair.target, pair.matches, pair.dense
        about = pair.verification
        if about is not None and "failed" in about:
            print(f"darcyan: warning: {target}: the matches were not verified: {about['failed']}", file=sys.stderr)
        elif about is not None:
            print(f"darcyan: {target}: verified{about['why']}{' (cached)' if about['cached'] else ''}: "
                  f"{_seed_verdict(about)}", file=sys.stderr)
        shapes = pair.shapes
        if shapes is None and (args.plot or args.html or args.truth):
            shapes = (load_shape(args.source, config, args.repair, warn=False),
                      load_shape(target, config, args.repair, warn=False))
        score = None
        if args.truth:
            truth = read_truth(args.truth, result.descriptions[0].n_input_vertices,
                               result.descriptions[1].n_input_vertices)
            score = score_matches(shapes[0], shapes[1], correspondence, truth)
            print(f"darcyan: {score.summary()}", file=sys.stderr)
        scored = None
        if dense is not None:
            scored = _say_dense(say, target, args.source, dense, shapes, truth if args.truth else None, args.quiet)
        if (args.plot or args.html) and args.dense:  # the dense map: texture transfer, errors with --truth
            from .viz.scenes import dense_scene

            scene = dense_scene(shapes[0], shapes[1], dense, truth if args.truth else None, scored=scored)
            _pictures(scene, args.plot, args.html, "render_dense", "dense_html")
        elif args.plot or args.html:
            from .viz.scenes import match_scene

            scene = match_scene(shapes[0], shapes[1], correspondence, config=config, score=score)
            _pictures(scene, args.plot, args.html, "render_matches", "matches_html")
    if args.dense and several:
        result.to_json(args.output) if form == "json" else result.to_csv(args.output)
        say(f"{len(result)} dense maps written to {args.output}")
    else:
        _write_text(result.text(form), args.output)
    return 0


def _say_dense(say, target: str, source: str, dense, shapes, truth, quiet: bool = False):
    """What ``darcyan match --dense`` says of a map: how it was started and checked, whether it is
    trusted (``quiet``: only when it is not), its score against ``truth`` (when given) and the
    vertices it left unmapped. Returns
    the score (a :class:`~darcyan.eval.dense_scores.DenseEvaluation`, or ``None``), which the
    picture draws."""
    from .dense.maps import UNMAPPED

    check = dense.check
    say(f"dense map: {_seed_verdict(check.verdict.as_dict())}; orientation agreement {check.orientation:.2f} (1: kept, "
        f"-1: mirrored), landmark distortion {check.distortion:.3f} sqrt(area)")
    if check.trusted:
        if not quiet:  # --quiet: warnings only
            print(f"darcyan: {target}: dense map trusted", file=sys.stderr)
    else:
        why = "; ".join(check.doubts) or "see DenseMap.check"
        print(f"darcyan: warning: {target}: dense map not trusted ({why}): look at it (--plot)", file=sys.stderr)
    scored = None
    if truth is not None:
        from .eval.dense_scores import evaluate_dense

        say("dense map: scoring it against the ground truth")
        scored = evaluate_dense(shapes[0].mesh, shapes[1].mesh, dense.target, truth, target_solver=shapes[1].solver)
        print(f"darcyan: dense map: {int((scored.errors <= scored.threshold).sum())} of {len(scored.errors)} "
              f"vertices within {scored.threshold:g} sqrt(area), mean error {scored.mean:.4f}", file=sys.stderr)
    left_out = int((dense.target == UNMAPPED).sum())
    if left_out:
        print(f"darcyan: warning: {source}: {left_out} vertices outside the matched component "
              f"are written with target_vertex {UNMAPPED}", file=sys.stderr)
    return scored


def _dense_folder(output: str | None, targets: list) -> None:
    """Make the folder of the dense maps of several targets, before any computation; refuse a
    file there, and targets whose maps would take the same name."""
    if output is None:
        raise DarcyanError("--dense with several targets writes one map per target: give -o FOLDER")
    stems = [Path(t).stem for t in targets]
    twice = sorted({s for s in stems if stems.count(s) > 1})
    if twice:
        raise DarcyanError(f"--dense: several targets are named {twice[0]!r}; their maps would overwrite each "
                           f"other in {output}: match them one by one")
    try:
        Path(output).mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise DarcyanError(f"{output}: cannot make the folder for the maps ({exc.strerror or exc})") from None


def _check_output(output: str | None, suffixes: tuple) -> None:
    """Before any work: a file ``-o`` names has one of ``suffixes`` (the formats written; none:
    CSV) and can be written (its folder exists and takes files, the file itself if it exists)."""
    import os

    if output is None or output == "-":
        return
    path = Path(output)
    if path.suffix.lower() not in suffixes:
        raise DarcyanError(f"{output}: unknown output format {path.suffix!r} (write "
                           f"{' or '.join(x for x in suffixes if x) or 'CSV'})")
    folder = path.resolve().parent
    if not folder.is_dir():
        raise DarcyanError(f"{output}: cannot write (no such folder)")
    if path.is_dir() or not os.access(path if path.exists() else folder, os.W_OK):
        raise DarcyanError(f"{output}: cannot write ({'a folder' if path.is_dir() else 'permission denied'})")


def _output_format(args: argparse.Namespace) -> str:
    """``--format``, else ``json`` for an ``-o *.json``, else ``csv``."""
    if args.format:
        return args.format
    return "json" if args.output and Path(args.output).suffix.lower() == ".json" else "csv"


def _seed_verdict(about: dict) -> str:
    """What the seed check (a :class:`~darcyan.dense.seeds.SeedVerdict` as a dict:
    ``DenseMap.check.verdict`` or ``verified_matches``' second result) decided, and whether the map
    was made on copies cut open at their handles."""
    cuts = about.get("handles_cut", 0)
    if not cuts:
        return _seed_choice(about)
    return (_seed_choice(about) + f"; made on copies of the shapes cut open at {cuts} handle{'s' * (cuts > 1)} "
            f"(parts joined where they touch?): the map on the meshes as given was not trusted, and this one "
            f"agrees better with its landmarks' orientation and is followed more closely by the alignment")


def _seed_choice(about: dict) -> str:
    """Which seed the seed check chose, and how plainly (:func:`_seed_verdict`)."""
    start_from = about.get("start_from", "the spectra")
    close = "" if about["clear"] else "; another candidate scores close: look at the matches (--plot)"
    rival = about.get("rival")
    if about.get("start") == "spectral" and rival is not None and about.get("by_checks"):
        return (f"started without the feature matches: the map from the matchings was not trusted, and the map "
                f"from landmarks of a short map started from {start_from} agrees better with its landmarks' "
                f"orientation and is followed more closely by the alignment (its signature scored no better); the "
                f"feature matches are read from the map")
    if about.get("start") == "spectral" and rival is not None:
        return (f"started without the feature matches: the map from the matchings was not trusted, and landmarks "
                f"from a short map started from {start_from} keep the shapes' curvature clearly better; the feature "
                f"matches are read from the map" + close)
    if about.get("start") == "spectral":
        return (f"started without the feature matches (fewer than 3 consistent ones): landmarks from a short map "
                f"started from {start_from}; the feature matches are read from the map")
    if about.get("start", "matches") == "matches" and about["seed"] == 0 and about.get("by_checks"):
        return ("the feature matches hold: an alternative matching's short map kept the shapes' curvature "
                "better, but its map was not trusted, and the feature matches' own map agrees better with its "
                "landmarks' orientation and is followed more closely by the alignment")
    lost = ""
    if rival is not None:
        signatures = about["signatures"]
        rival_score = signatures.get(rival, signatures.get(str(rival)))  # JSON records key ranks by strings
        if rival_score is not None and rival_score < about["signature"]:  # it scored better, its map refused
            lost, close = ("; a start without the feature matches scored better, but its map was not taken (the "
                           "alignment followed it less closely, or its own checks did not beat this map's)"), ""
        else:
            lost = "; a start without the feature matches was weighed against it and did not score better"
    left_out = about.get("left_out")
    if left_out is not None:  # before the rival's verdict: it was weighed against the map without the pair
        source, target, displacement = left_out
        lost = (f"; the landmark pair {source} -> {target} left out (the other pairs sent its source "
                f"{displacement:.2f} sqrt(area) away), the feature matches read from the map") + lost
    if about["seeds"] - (rival is not None) == 1:  # the matchings' seeds, the rival aside
        return ("the feature matches, no alternative matching to weigh them against" if about["seed"] == 0 else
                f"alternative matching {about['seed']}: the feature matches have too few consistent matches") + lost + close
    if about["seed"] == 0:
        verdict = "the feature matches hold against their alternatives"
    elif about.get("by_checks"):  # the best-scored seed over the first, which the margin had kept
        first = ("the feature matches' own map" if 0 in about["signatures"] else
                 "the first usable alternative's map (the feature matches have too few consistent matches)")
        verdict = (f"alternative matching {about['seed']} replaces the feature matches: its short dense map kept "
                   f"the shapes' curvature a little better (within the margin that favours the first), {first} "
                   f"was not trusted, and this one agrees better with its landmarks' orientation and is followed "
                   f"more closely by the alignment")
    elif 0 not in about["signatures"]:
        verdict = (f"alternative matching {about['seed']} replaces the feature matches (they have too few "
                   f"consistent matches)")
    else:
        verdict = (f"alternative matching {about['seed']} replaces the feature matches (its short dense map keeps "
                   f"the shapes' curvature clearly better)")
    return verdict + lost + close


def _progress(args: argparse.Namespace):
    """``say(text)``: a ``darcyan: ...`` line on stderr with the seconds so far, unless ``--quiet``."""
    import time

    start = time.perf_counter()
    if getattr(args, "quiet", False):
        return lambda text: None
    return lambda text: print(f"darcyan: [{time.perf_counter() - start:5.1f} s] {text}", file=sys.stderr, flush=True)


def _picture_dependencies(args: argparse.Namespace) -> None:
    """Fail before any computation when a requested picture's optional library is missing."""
    from .errors import require

    for target in (getattr(args, "plot", None), args.html, args.output if args.command == "show-grid" else None):
        if target and not Path(target).resolve().parent.is_dir():
            raise DarcyanError(f"{target}: cannot write (no such folder)")
    if getattr(args, "plot", None) or (getattr(args, "output", None) and args.command == "show-grid"):
        require("matplotlib", "plot")
    if args.html:
        require("plotly", "html")


def _pictures(scene, png: str | None, html: str | None, render: str, page: str) -> None:
    """Write the PNG and/or HTML picture of ``scene``; one line per file on stderr."""
    from .viz import html as viewer
    from .viz import scenes as viz

    if png:
        picture = getattr(viz, render)(scene, png)
        print(f"darcyan: wrote {picture.path} ({picture.seconds:.1f} s)", file=sys.stderr)
    if html:
        print(f"darcyan: wrote {getattr(viewer, page)(scene, html)}", file=sys.stderr)


def cmd_show_grid(args: argparse.Namespace) -> int:
    from .viz.scenes import grid_scene

    if not args.output and not args.html:
        raise DarcyanError("show-grid: give -o FILE.png and/or --html FILE.html")
    _picture_dependencies(args)
    scene = grid_scene(args.mesh, vertex=args.vertex, feature=args.feature, config=_config(args),
                       curvature=args.curvature, repair=args.repair)
    _pictures(scene, args.output, args.html, "render_grid", "grid_html")
    return 0


def cmd_features(args: argparse.Namespace) -> int:
    from .method.pipeline import describe_shape

    _check_output(args.output, ("", ".csv", ".txt"))
    shape = describe_shape(args.mesh, _config(args), args.repair, _cache(args))
    _note_changes(shape)
    lines = ["vertex,agd"] + [f"{v},{a:.6g}" for v, a in zip(shape.feature_vertices, shape.feature_agd)]
    _write_text("\n".join(lines) + "\n", args.output)
    return 0


def cmd_describe(args: argparse.Namespace) -> int:
    from .method.pipeline import describe_shape

    config = _config(args)
    _check_output(args.output, (".npz", ".csv"))
    shape = describe_shape(args.mesh, config, args.repair, _cache(args))
    _note_changes(shape)
    out = Path(args.output)
    if out.suffix.lower() == ".npz":
        try:
            np.savez(out, vertex=shape.feature_vertices, agd=shape.feature_agd, descriptor=shape.descriptors,
                     config=np.array(str(config.as_dict())))
        except OSError as exc:
            raise DarcyanError(f"{out}: cannot write ({exc.strerror or exc})") from None
    elif out.suffix.lower() == ".csv":
        names = [f"k{k + 1}{kind}" for k in range(config.levels) for kind in ("max", "min")]
        lines = [",".join(["vertex", "agd"] + names)]
        for v, a, d in zip(shape.feature_vertices, shape.feature_agd, shape.descriptors):
            lines.append(",".join([str(v), f"{a:.6g}"] + [f"{x:.6g}" for x in d]))
        _write_text("\n".join(lines) + "\n", str(out))
    else:
        raise DarcyanError(f"{out}: output must end in .npz or .csv")
    return 0


def cmd_demo(args: argparse.Namespace) -> int:
    from .demo import run_demo

    result = run_demo(progress=lambda msg: print(msg, file=sys.stderr))
    print(result.report())
    return 0


def cmd_bench(args: argparse.Namespace) -> int:
    from .bench.report import report_markdown
    from .bench.runner import run_bench

    result = run_bench(args.dataset, args.out, methods=args.method, pairs_file=args.pairs, threshold=args.threshold,
                       config=_config(args), jobs=args.jobs, scheduler=args.scheduler, resume=args.resume,
                       repair=args.repair, laplacian=args.laplacian, no_cache=args.no_cache,
                       progress=not args.quiet, dense=args.dense, dense_samples=args.dense_samples)
    if not args.quiet:
        print(report_markdown(result.results))
    print(f"darcyan: {result.computed} results computed (matchings and dense maps, per method and pair), "
          f"{result.reused} reused; "
          f"{result.seconds:.0f} s; results in {result.out}", file=sys.stderr)
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="darcyan",
        description="Correspondences between non-rigid 3D shapes with the Darcyan curvature descriptor "
                    "(Sboui et al.).")
    parser.add_argument("--version", action="version", version=f"darcyan {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    p = sub.add_parser("match", help="match the feature points of two meshes",
                       description="Match the extremities of SOURCE to those of TARGET. Writes CSV "
                                   "source_vertex,target_vertex,distance (0-based vertex indices of the files).")
    p.add_argument("source", help="mesh file (.off .obj .ply .stl .glb .gltf .vert/.tri)")
    p.add_argument("targets", nargs="+", metavar="target", help="one or more mesh files, each matched with the source "
                   "(described once)")
    p.add_argument("-o", "--output", help="file to write (default: stdout); with several targets and --dense, a folder "
                   "that gets one map per target")
    p.add_argument("--format", choices=("csv", "json"), help="output format (default: json for -o *.json, else csv); "
                   "with several targets the CSV gains a leading target column")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress lines on stderr")
    p.add_argument("--matching", choices=MATCHING_MODES,
                   help="nearest: the paper's nearest descriptor; one-to-one: optimal assignment; consistent: "
                        f"geodesic layout and orientation too (default {DarcyanConfig().matching})")
    p.add_argument("--dense", action="store_true", help="write a dense map instead: CSV source_vertex,target_vertex, "
                   "one row per source vertex, seeded by the feature matches (geodesic landmark coordinates refined by ZoomOut)")
    p.add_argument("--ensemble", type=int, metavar="N",
                   help="with --dense: combine N ZoomOut runs from independent surface samples, per vertex the "
                        "medoid of the N images (N >= 3; 1 or 2: one run, the default). With 3: -0.2 to +0.6 point "
                        "within 0.05, the mean error up to 5%% lower, a match 1.5-1.9x as long (docs/decisions/)")
    p.add_argument("--sampling", choices=("random", "farthest"),
                   help="with --dense: the samples ZoomOut iterates on, drawn at random by area (the default) or "
                        "farthest-point samples, with which the map does not depend on the vertices' numbering "
                        "(but for --ensemble's other runs, which draw at random; docs/decisions/)")
    verify = p.add_mutually_exclusive_group()
    verify.add_argument("--verify", action="store_true", help="weigh the feature matches against the other matchings "
                        "the orientation test considered by short dense maps (which keeps the shapes' curvature "
                        "better?) and write the winner: fixes mirrored matches of people (about 1.5 s more for "
                        "5k-vertex shapes). Done by default, without --dense, when the test's margin is below "
                        "mirror.verify_sparse_below (0.75) or it is in doubt (below mirror.verify_below)")
    verify.add_argument("--no-verify", action="store_true", help="never verify: the matches of the descriptors and the "
                        "orientation test alone")
    p.add_argument("--jobs", type=int, default=2, help="processes describing the two shapes at once when neither "
                   "is in the cache (default %(default)s)")
    p.add_argument("--plot", metavar="FILE.png", help="also draw the matches side by side to a PNG (with --dense: the "
                   "dense map, source coloured by position, target through the map, errors with --truth; "
                   "pip install 'darcyan[plot]')")
    p.add_argument("--html", metavar="FILE.html", help="also write an interactive, self-contained HTML view (pip install 'darcyan[html]')")
    p.add_argument("--truth", metavar="identity|A.vts,B.vts", help="ground truth: print 'k of n matches correct' "
                   "(geodesic error <= 0.05 sqrt(area)) on stderr and mark wrong matches in the pictures; 'identity' = "
                   "the same vertex numbering (same vertex counts)")
    _add_config_options(p)
    p.set_defaults(func=cmd_match)

    p = sub.add_parser("show-grid", help="draw the Darcyan grid around a point (PNG and/or interactive HTML)",
                       description="Draws the surface around a feature point (default: feature 0) or a vertex, "
                                   "the n geodesic level curves and m radial lines of its Darcyan grid, and the "
                                   "intersection points coloured by curvature, seen from in front of the point.")
    p.add_argument("mesh", help="mesh file (.off .obj .ply .stl .glb .gltf .vert/.tri)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--vertex", type=int, metavar="V", help="centre: vertex V of the file (0-based)")
    where.add_argument("--feature", type=int, metavar="K", help="centre: feature point K (0-based row of 'darcyan features'; default 0)")
    p.add_argument("--curvature", choices=("kmax", "kmin"), default="kmax", help="colour the points by (default %(default)s)")
    p.add_argument("-o", "--output", metavar="FILE.png", help="PNG to write (pip install 'darcyan[plot]')")
    p.add_argument("--html", metavar="FILE.html", help="interactive, self-contained HTML to write (pip install 'darcyan[html]')")
    _add_config_options(p)
    p.set_defaults(func=cmd_show_grid)

    p = sub.add_parser("features", help="list the feature points (AGD maxima) of a mesh",
                       description="Writes CSV vertex,agd: 0-based vertex index in the file, AGD in sqrt(area) units.")
    p.add_argument("mesh")
    p.add_argument("-o", "--output", help="CSV file to write (default: stdout)")
    _add_config_options(p)
    p.set_defaults(func=cmd_features)

    p = sub.add_parser("describe", help="feature points and their Darcyan descriptors",
                       description="Writes the feature points, their AGD and descriptors [k1max, k1min, ...] "
                                   "to an .npz (arrays vertex, agd, descriptor) or .csv file.")
    p.add_argument("mesh")
    p.add_argument("-o", "--output", required=True, help="output file, .npz or .csv")
    _add_config_options(p)
    p.set_defaults(func=cmd_describe)

    p = sub.add_parser("demo", help="run the whole method on a built-in synthetic figure in two poses",
                       description="Matches a built-in articulated figure against a bent copy with known "
                                   "ground truth and prints the matches and how many are correct.")
    p.set_defaults(func=cmd_demo)

    from .bench import METHODS
    from .eval.dense_scores import DENSE_SAMPLE, DENSE_SEED
    from .eval.metrics import DEFAULT_THRESHOLD

    p = sub.add_parser("bench", help="correspondence rates on a dataset folder, darcyan and baselines side by side",
                       description="Match every ordered pair within each class of DATASET_DIR ({class}{pose}.off|ply|obj; "
                                   "ground truth corres/{shape}.vts, else the identity on vertex indices) with each "
                                   "method at darcyan's feature points, and write results.json, pairs.csv, "
                                   "report.md, rates.png and curve.png to --out (with --dense also dense maps, "
                                   "scored on sampled source vertices, and dense_curve.png).")
    p.add_argument("dataset", metavar="DATASET_DIR", help="folder of meshes named {class}{pose}")
    p.add_argument("--pairs", metavar="FILE", help="tab-separated 'source<TAB>target' lines (default: every ordered pair within a class)")
    p.add_argument("--method", nargs="+", choices=METHODS, default=["darcyan"], help="methods to evaluate (default darcyan)")
    p.add_argument("--threshold", type=float, default=DEFAULT_THRESHOLD,
                   help="a match is correct when its geodesic error / sqrt(area) is at most this (default %(default)s)")
    p.add_argument("--out", default="bench-results", help="output folder (default %(default)s)")
    p.add_argument("--jobs", type=int, default=1, help="local worker processes (default %(default)s)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="run on a dask.distributed scheduler (pip install 'darcyan[dask]')")
    p.add_argument("--resume", action="store_true", help="keep the finished pairs in --out and compute only the others")
    p.add_argument("--dense", action="store_true", help="also score dense maps per pair: darcyan's (seeded by its "
                   "sparse matches) and, when pyfm is a --method, pyFM's own pipeline without darcyan's landmarks; "
                   "cumulative curve in dense_curve.png, results under 'dense' in results.json")
    p.add_argument("--dense-samples", type=int, default=DENSE_SAMPLE, metavar="N",
                   help=f"source vertices scored per pair with --dense, drawn at random with seed {DENSE_SEED} "
                        "(among the listed corres/*.vts samples for vts data) (default %(default)s)")
    p.add_argument("--laplacian", choices=("cotangent", "robust"), default="cotangent",
                   help="Laplace-Beltrami operator of hks/wks (default %(default)s)")
    p.add_argument("--matching", choices=MATCHING_MODES,
                   help=f"descriptor matching of darcyan/hks/wks (default {DarcyanConfig().matching})")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar and no table on stdout")
    _add_config_options(p)
    p.set_defaults(func=cmd_bench)
    return parser


@contextlib.contextmanager
def _thread_limit(threads: int | None):
    """The library's thread policy (:mod:`darcyan.parallel`) set to ``--threads`` (when given) for
    the whole command (its own work between the library's calls included), and set back after."""
    from .parallel import _threads, limited_threads, set_threads

    if threads is not None and threads < 0:
        raise DarcyanError(f"--threads must be 0 (the libraries' default) or more, got {threads}")
    before = _threads["count"]
    if threads is not None:
        set_threads(threads)
    try:
        with limited_threads():
            yield
    finally:
        _threads["count"] = before


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)

    def show_warning(message, category, filename, lineno, file=None, line=None):
        print(f"darcyan: warning: {message}", file=sys.stderr)

    warnings.showwarning = show_warning
    warnings.simplefilter("ignore")  # library noise (numpy, trimesh) is not the user's business
    warnings.simplefilter("always", MeshWarning)
    try:
        with _thread_limit(getattr(args, "threads", None)):
            return args.func(args)
    except DarcyanError as exc:
        print(f"darcyan: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("darcyan: interrupted", file=sys.stderr)
        return 130
    except MemoryError:
        print("darcyan: error: out of memory", file=sys.stderr)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
