"""`waamflow` command line: run | nodes | serve | openapi (see CONTRACT.md).

Exit codes: 0 done; 2 invalid recipe; 3 planning failure; 4 preflight failed (the program would build
the wrong part; `--accept-preflight` writes it anyway); 130 cancelled (Ctrl-C).
On failure one line on stderr starting `error:` names the node, layer and section.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

from . import __version__
from .core.errors import CancelledError, RecipeError, WaamflowError


def _cache_path() -> Path:
    base = os.environ.get("WAAMFLOW_CACHE") or os.path.join(
        os.environ.get("XDG_CACHE_HOME", os.path.expanduser("~/.cache")), "waamflow"
    )
    return Path(base) / "cache.sqlite"


# Warnings printed on stderr at most (all of them with -v): a soup of 100 loose triangles read as a
# surface gave 20,701 wall warnings, 20,706 lines; every warning is in summary.json either way.
MAX_PRINTED_WARNINGS = 50


class ProgressBar:
    """Progress on stderr: a redrawn bar on a terminal, one line per node otherwise (with -v);
    warnings as they come, the first MAX_PRINTED_WARNINGS of them unless verbose, then a count."""

    def __init__(self, stream, verbose: bool) -> None:
        self.stream = stream
        self.tty = stream.isatty()
        self.verbose = verbose
        self.last = ""
        self.shown = 0
        self.hidden: dict[str, int] = {}  # node → warnings not printed

    def __call__(self, ev) -> None:
        if self.tty:
            if ev.kind in ("node_started", "node_progress"):
                width = 30
                filled = int(ev.progress * width)
                text = (
                    f"\r[{'#' * filled}{'.' * (width - filled)}] {ev.progress * 100:5.1f}% {ev.node or ''} {ev.message}"
                )
                self.stream.write(text[:100].ljust(len(self.last)))
                self.last = text[:100]
                self.stream.flush()
            elif ev.kind in ("run_finished", "run_failed", "run_cancelled") and self.last:
                self.stream.write("\r" + " " * len(self.last) + "\r")
                self.stream.flush()
        if ev.kind == "warning":
            if self.verbose or self.shown < MAX_PRINTED_WARNINGS:
                self.shown += 1
                self._line(
                    f"warning: {ev.node}: " + (f"layer {ev.layer}: " if ev.layer is not None else "") + ev.message
                )
            else:
                self.hidden[ev.node or "run"] = self.hidden.get(ev.node or "run", 0) + 1
        elif ev.kind in ("run_finished", "run_failed", "run_cancelled") and self.hidden:
            counts = ", ".join(f"{node} {n}" for node, n in sorted(self.hidden.items(), key=lambda kv: -kv[1]))
            self._line(
                f"warning: {sum(self.hidden.values())} more warnings not shown ({counts}): all are in "
                "summary.json; -v prints them"
            )
            self.hidden = {}
        elif self.verbose and ev.kind in ("node_finished", "node_cached"):
            tag = "cached" if ev.kind == "node_cached" else f"{ev.seconds:.3f} s"
            self._line(f"  {ev.node} ({ev.message}): {tag}")

    def _line(self, text: str) -> None:
        if self.tty and self.last:
            self.stream.write("\r" + " " * len(self.last) + "\r")
            self.last = ""
        self.stream.write(text + "\n")
        self.stream.flush()


# A recipe with a mesh file of this many triangles (by its size: 50 bytes each) starts multiprocessing's
# fork server first thing, before the engine's imports (~0.35 s): the server's own imports (every
# node module, ~0.5 s of CPU) then run beside the parent's, and the layer workers fork from it ~0.3 s
# sooner, in time for the slicer to cut its upper planes in one. engine.executor.WARM_TRIANGLES and
# engine.parallel.PRELOAD (tests/cli/test_cli.py holds them equal); the engine still decides whether
# to start workers at all.
EARLY_FORK_SERVER_TRIANGLES = 250_000
FORK_SERVER_PRELOAD = ["waamflow.engine.warm"]
MESH_SUFFIXES = (".stl", ".obj", ".ply", ".off", ".3mf")


def _early_fork_server(recipe_path: Path, workers: int | None, scheduler: str | None) -> bool:
    """Start the fork server when the recipe reads a large mesh file and the run may use layer
    workers; True if started. Anything unreadable is left to the run to report."""
    env = os.environ.get("WAAMFLOW_LAYER_WORKERS", "")
    count = workers if workers is not None else (int(env) if env.isdigit() else (os.cpu_count() or 1))
    if count < 2 or scheduler:
        return False
    try:
        nodes = json.loads(recipe_path.read_text(encoding="utf-8")).get("nodes", [])
        paths = [
            v
            for n in nodes
            if isinstance(n, dict) and isinstance(n.get("params"), dict)
            for v in n["params"].values()
            if isinstance(v, str) and v.lower().endswith(MESH_SUFFIXES)
        ]
        base = recipe_path.resolve().parent
        big = any((base / p).stat().st_size // 50 >= EARLY_FORK_SERVER_TRIANGLES for p in paths)
    except (OSError, ValueError, AttributeError):
        return False
    if not big:
        return False
    import multiprocessing as mp
    from multiprocessing import forkserver

    mp.get_context("forkserver").set_forkserver_preload(FORK_SERVER_PRELOAD)
    forkserver.ensure_running()
    return True


def cmd_run(args) -> int:
    _early_fork_server(Path(args.recipe), args.workers, args.scheduler or os.environ.get("WAAMFLOW_SCHEDULER"))
    from .engine.artifacts import write_run_dir
    from .engine.cache import MemoryCache, SqliteCache, TieredCache
    from .engine.executor import FileResolver, execute
    from .engine.graph import build_graph
    from .engine.recipe import apply_overrides, load_recipe, parse_set

    recipe_path = Path(args.recipe)
    recipe = load_recipe(recipe_path)
    recipe = apply_overrides(recipe, parse_set(args.set or []))
    graph = build_graph(recipe)
    out = Path(args.out) if args.out else Path("out") / recipe.name
    cache = None
    if not args.no_cache:
        try:
            cache = TieredCache(MemoryCache(), SqliteCache(_cache_path()))
        except Exception as e:  # an unwritable cache folder must not stop a run
            print(f"warning: cache disabled ({e})", file=sys.stderr)
            cache = TieredCache(MemoryCache())
    bar = ProgressBar(sys.stderr, args.verbose)
    if args.workers is not None and args.workers < 1:
        raise RecipeError(f"--workers must be at least 1 (got {args.workers})")
    scheduler = args.scheduler or os.environ.get("WAAMFLOW_SCHEDULER") or None
    result = execute(
        graph,
        resolver=FileResolver(recipe_path.resolve().parent),
        cache=cache,
        on_event=bar,
        workers=args.workers,
        scheduler=scheduler,
    )
    summary = result.summary(recipe.name)
    summary["inputs"] = recipe.inputs
    from .preflight import gate

    files, failed = gate(result.preflight, result.artifacts, args.accept_preflight, "--accept-preflight")
    if failed is not None and not args.accept_preflight:
        summary["status"] = "preflight_failed"
    summary["preflight"] = result.preflight
    summary["artifacts"] = sorted(files)
    write_run_dir(out, files, summary)
    n_cached = sum(1 for s in result.stats.values() if s.cached)
    spent = {k: s.compute_seconds for k, s in result.stats.items() if s.compute_seconds}
    if args.verbose and spent and result.executor.get("tasks"):
        # in worker processes a chain's first node waits for its followers' layers too: say who computed what
        print(
            "  layer compute, all processes: " + ", ".join(f"{k} {v:.3f} s" for k, v in spent.items()), file=sys.stderr
        )
    pf = result.preflight
    verdict = f", preflight {pf['verdict']}" + (" (accepted)" if pf.get("accepted") else "") if pf else ""
    if pf:
        for p in pf["problems"]:
            where = "".join(
                [
                    f"layer {p['layer']}: " if p.get("layer") is not None else "",
                    f"section '{p['section']}': " if p.get("section") else "",
                ]
            )
            print(f"preflight {p['severity']}: {p['node']}: {where}{p['message']}", file=sys.stderr)
    if failed is not None and not args.accept_preflight:
        where = ", ".join(
            x
            for x in (
                f"layer {failed['layer']}" if failed.get("layer") is not None else "",
                f"section '{failed['section']}'" if failed.get("section") else "",
            )
            if x
        )
        who = f"node '{failed['node']}'" if failed.get("node") else "preflight"
        print(
            f"error: {who}{', ' + where if where else ''}: preflight failed ({failed['check']}): "
            f"{failed['message']}. The program was not written ({out}/preflight.json says why); fix the plan, "
            "or re-run with --accept-preflight to write it anyway (recorded in its header)",
            file=sys.stderr,
        )
        return 4
    print(
        f"done: {len(result.stats)} nodes ({n_cached} cached), {result.layer_count or 0} layers, "
        f"{len(result.warnings)} warning{'' if len(result.warnings) == 1 else 's'}{verdict}, {result.seconds:.2f} s → {out}"
    )
    return 0


def cmd_build_sim(args) -> int:
    from .asbuilt.run import build_sim, write
    from .asbuilt.sim import Disturbance
    from .engine.recipe import parse_set

    path = Path(args.recipe)
    modes = ("open", "closed") if args.mode == "both" else (args.mode,)
    doc = build_sim(path, parse_set(args.set or []), modes, Disturbance(seed=args.seed))
    out = Path(args.out) if args.out else Path("out") / doc["recipe"]
    files = write(doc, out)
    print(f"{doc['recipe']}: {doc['layers_planned']} layers planned (toolpath of '{doc['toolpath_node']}')")
    for mode, b in doc["builds"].items():
        print(
            f"  {mode:6s} loop: last layer top error RMS {b['last_layer_rms_mm']:.3f} mm, max {b['last_layer_max_mm']:.3f} mm, "
            f"mean {b['last_layer_mean_mm']:+.3f} mm; {b['layers_built']} layers built "
            f"({b['layers_added']} added, {b['layers_dropped']} dropped), {b['seconds']:.2f} s"
        )
    print(f"wrote {', '.join(str(f) for f in files)}")
    return 0


def cmd_nodes(args) -> int:
    from .engine.node import catalog

    cat = catalog()
    if args.type:
        cat = [c for c in cat if c["type"] == args.type]
        if not cat:
            raise RecipeError(f"unknown node type {args.type!r}")
    json.dump({"waamflow": __version__, "nodes": cat}, sys.stdout, indent=2)
    sys.stdout.write("\n")
    return 0


def cmd_profiles(args) -> int:
    from .program.profiles import load_profiles

    json.dump({"waamflow": __version__, "profiles": list(load_profiles().values())}, sys.stdout, indent=2)
    sys.stdout.write("\n")
    return 0


def cmd_serve(args) -> int:
    import uvicorn

    from .api.app import create_app
    from .settings import Settings

    from pydantic import ValidationError

    from .api.auth import load_tokens

    # a flag overrides its WAAMFLOW_* variable (docker/compose.yml sets them); unset flags leave it
    given = {
        "data_dir": args.data,
        "host": args.host,
        "port": args.port,
        "viewer_port": args.viewer_port,
        "graphs_dir": args.graphs,
        "layer_workers": args.layer_workers,
        "scheduler": args.scheduler,
        "token_file": args.token_file,
        "max_connections": args.max_connections,
        "header_timeout_s": args.header_timeout,
        "run_memory_mb": args.run_memory_mb,
    }
    try:
        settings = Settings(**{k: v for k, v in given.items() if v is not None})
    except ValidationError as e:
        where = ", ".join(f"{'.'.join(str(x) for x in err['loc'])}: {err['msg']}" for err in e.errors())
        print(
            f"error: invalid server setting ({where}); see `waamflow serve --help` and the WAAMFLOW_* "
            "variables in README 'Lab server'",
            file=sys.stderr,
        )
        return 2
    tokens = load_tokens(settings.token, settings.token_file)  # TokenFileError → exit 2
    if not tokens and not _loopback(settings.host):
        print(
            f"error: refusing to serve on {settings.host} without authentication: set a token with "
            "WAAMFLOW_TOKEN=<secret> (e.g. `export WAAMFLOW_TOKEN=$(python -c 'import secrets; "
            "print(secrets.token_urlsafe(32))')`) or --token-file FILE / WAAMFLOW_TOKEN_FILE (lines name:token), "
            "or serve on 127.0.0.1",
            file=sys.stderr,
        )
        return 2
    app = create_app(settings)
    from .api.serving import uvicorn_options

    uvicorn.run(app, host=settings.host, port=settings.port, log_level="info", **uvicorn_options(settings))
    return 0


def _loopback(host: str) -> bool:
    import ipaddress

    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def cmd_backup(args) -> int:
    from .api.backup import backup

    m = backup(args.data, args.dir)
    c = m["counts"]
    print(
        f"backup: {c['graphs']} graphs, {c['graph_files']} files, {c['runs']} runs, "
        f"{len(m['files'])} run files, {c['audit']} audit entries → {args.dir}"
    )
    return 0


def cmd_restore(args) -> int:
    from .api.backup import restore

    m = restore(args.dir, args.data, force=args.force)
    c = m["counts"]
    print(
        f"restored: {c['graphs']} graphs, {c['graph_files']} files, {c['runs']} runs, "
        f"{len(m['files'])} run files → {args.data}"
    )
    if m.get("kept"):
        k = m["kept"]["counts"]
        print(f"kept aside: {k['graphs']} graphs, {k['graph_files']} files, {k['runs']} runs → {m['kept']['path']}")
    return 0


def cmd_openapi(args) -> int:
    from .api.app import create_app
    from .settings import Settings

    app = create_app(Settings(start_viewer=False, start_workers=False))
    json.dump(app.openapi(), sys.stdout, indent=2)
    sys.stdout.write("\n")
    return 0


def _add_run(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """The `run` command: a recipe headless, its artifacts written."""
    r = sub.add_parser("run", help="run a recipe headless and write its artifacts")
    r.add_argument("recipe", help="recipe JSON file (graphs/*.json)")
    r.add_argument("--out", help="output folder (default out/<recipe name>/)")
    r.add_argument(
        "--set",
        action="append",
        metavar="KEY=VALUE",
        help="set a recipe input (name=value) or node param (nodeid.param.sub=value); VALUE is JSON or a string",
    )
    r.add_argument("--no-cache", action="store_true", help="recompute everything, do not read or write the cache")
    r.add_argument("-v", "--verbose", action="store_true", help="one line per node")
    r.add_argument(
        "--accept-preflight",
        action="store_true",
        help="write the programs even when the preflight fails (exit 0; the acceptance is written into "
        "each program's header and preflight.json)",
    )
    r.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="processes for the layers of layer nodes (default: WAAMFLOW_LAYER_WORKERS, else every core; 1 = serial)",
    )
    r.set_defaults(func=cmd_run)

    r.add_argument(
        "--scheduler",
        default=None,
        metavar="tcp://HOST:PORT",
        help="send the layers to this Dask scheduler instead of local processes "
        "(default: WAAMFLOW_SCHEDULER; see README 'Dask cluster')",
    )


def _add_serve(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """The `serve` command: the web server and its limits."""
    s = sub.add_parser("serve", help="start the web server (GUI, REST API, 3D preview)")
    s.add_argument(
        "--host",
        default=None,
        help="address to listen on (default: WAAMFLOW_HOST, else 127.0.0.1; any other than loopback needs a token)",
    )
    s.add_argument("--port", type=int, default=None, help="default: WAAMFLOW_PORT, else 8000")
    s.add_argument(
        "--data", default=None, help="folder for the database and run files (default: WAAMFLOW_DATA_DIR, else ./data)"
    )
    s.add_argument(
        "--graphs",
        default=None,
        help="folder of example recipes to offer (default: WAAMFLOW_GRAPHS_DIR, else ./graphs)",
    )
    s.add_argument(
        "--viewer-port",
        type=int,
        default=None,
        help="port of the viser 3D preview (0 = off; default: WAAMFLOW_VIEWER_PORT, else 8080); it "
        "listens on 127.0.0.1 only and browsers reach it through this server's /viewer/ (same token)",
    )
    s.add_argument(
        "--workers",
        "--layer-workers",
        dest="layer_workers",
        type=int,
        default=None,
        metavar="N",
        help="processes per run for the layers of layer nodes, as `run --workers` (default: every core; 1 = serial)",
    )
    s.add_argument(
        "--scheduler",
        default=None,
        metavar="tcp://HOST:PORT",
        help="Dask scheduler for the layers of every run (default: WAAMFLOW_SCHEDULER)",
    )
    s.add_argument(
        "--token-file",
        default=None,
        help="named bearer tokens (JSON {name: token} or lines name:token; default: WAAMFLOW_TOKEN_FILE); "
        "also WAAMFLOW_TOKEN",
    )
    s.add_argument(
        "--max-connections",
        type=int,
        default=None,
        metavar="N",
        help="open connections at once; more are closed at once (default: WAAMFLOW_MAX_CONNECTIONS, else 1000)",
    )
    s.add_argument(
        "--header-timeout",
        type=float,
        default=None,
        metavar="S",
        help="seconds a connection has to send its request head (default: WAAMFLOW_HEADER_TIMEOUT_S, else 10)",
    )
    s.add_argument(
        "--run-memory-mb",
        type=float,
        default=None,
        metavar="MB",
        help="memory of one run's whole process tree (the run and its layer workers together), and "
        "of a preview's; a run or preview that needs more fails (default: WAAMFLOW_RUN_MEMORY_MB, "
        "else half the machine's memory; 0 = runs and previews in the server process, unlimited)",
    )
    s.set_defaults(func=cmd_serve)


def _add_backup_restore(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """The `backup` and `restore` commands of the server's data folder."""
    b = sub.add_parser("backup", help="back up the server's database (online, safe while it runs) and run files")
    b.add_argument("dir", help="new folder for the backup")
    b.add_argument(
        "--data",
        default=os.environ.get("WAAMFLOW_DATA_DIR", "data"),
        help="the server's data folder (default: WAAMFLOW_DATA_DIR, else ./data)",
    )
    b.set_defaults(func=cmd_backup)

    rs = sub.add_parser("restore", help="restore a backup into a data folder (refused while a server uses it)")
    rs.add_argument("dir", help="folder written by `waamflow backup`")
    rs.add_argument(
        "--data",
        default=os.environ.get("WAAMFLOW_DATA_DIR", "data"),
        help="the server's data folder (default: WAAMFLOW_DATA_DIR, else ./data)",
    )
    rs.add_argument("--force", action="store_true", help="replace the existing database instead of keeping it aside")
    rs.set_defaults(func=cmd_restore)


def _add_build_sim(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """The `build-sim` command: open and closed loop in the process simulator."""
    bs = sub.add_parser(
        "build-sim",
        help="build a recipe in the process simulator, open and closed loop "
        "(scans after every layer, the next layer adapted), and compare",
    )
    bs.add_argument("recipe", help="recipe JSON file (graphs/*.json)")
    bs.add_argument("--set", action="append", metavar="KEY=VALUE", help="as for `run` (e.g. layers.layer_count=20)")
    bs.add_argument("--out", help="output folder for asbuilt.json and asbuilt.svg (default out/<recipe name>/)")
    bs.add_argument("--mode", choices=("both", "open", "closed"), default="both")
    bs.add_argument("--seed", type=int, default=1, help="random seed of the simulated noise")
    bs.set_defaults(func=cmd_build_sim)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="waamflow", description="Node-graph CAM for Wire + Arc Additive Manufacturing")
    p.add_argument("--version", action="version", version=f"waamflow {__version__}")
    p.add_argument("--debug", action="store_true", help="print tracebacks of internal errors")
    sub = p.add_subparsers(dest="cmd", required=True)

    _add_run(sub)
    n = sub.add_parser("nodes", help="print the node catalog as JSON")
    n.add_argument("--type", help="only this node type")
    n.set_defaults(func=cmd_nodes)

    pr = sub.add_parser("profiles", help="print the machine profiles (post-process 'profile' presets) as JSON")
    pr.set_defaults(func=cmd_profiles)

    _add_serve(sub)
    _add_backup_restore(sub)
    _add_build_sim(sub)

    o = sub.add_parser("openapi", help="print the REST API's OpenAPI schema")
    o.set_defaults(func=cmd_openapi)
    return p


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except CancelledError:
        print("error: cancelled", file=sys.stderr)
        return 130
    except KeyboardInterrupt:
        print("error: interrupted", file=sys.stderr)
        return 130
    except WaamflowError as err:
        print(f"error: {err}", file=sys.stderr)
        if args.debug and getattr(err, "debug_traceback", None):
            print(err.debug_traceback, file=sys.stderr)
        return err.exit_code
    except BrokenPipeError:
        return 0


if __name__ == "__main__":
    sys.exit(main())
