"""``cyborgd``: the rig's service (``run``), offline analysis, the PTU emulator."""

from __future__ import annotations

import argparse
import asyncio
import importlib
import logging
import os
import sys
from dataclasses import replace
from pathlib import Path

import cv2
import zenoh

from cyborg.protocol.aims import add_aim_argument
from cyborg.protocol.settings import add_settings_argument
from cyborg.protocol.transport import MODES
from cyborg.protocol.version import BUILD, PROTOCOL_MAJOR, PROTOCOL_MINOR

from .app import run
from .camera import CameraError
from .config import Config, load, validate
from .ptu import PtuError
from .ptu.emulator import Ptu46Emulator
from .ptu.models import MODELS
from .ptu.ptyserver import BANNER, PtyEmulatorServer, parse_fault, serve
from .router import run_router
from .tools.batch import PRODUCTS
from .vision.params import PROFILES, profile, with_settings
from .zenohlog import route_zenoh_logs

_LOGGER = logging.getLogger(__name__)


def _run_parser(sub: argparse._SubParsersAction) -> None:
    ap = sub.add_parser("run", help="serve the rig on the bus (the systemd service runs this)")
    ap.add_argument("--config", type=Path, help="TOML config file (see systemd/cyborgd.toml)")
    ap.add_argument("--rig", help="rig name: keys live under cyborg/<rig>/")
    ap.add_argument("--ptu", metavar="URL", help="serial:///dev/ptu, pty://..., emu://...")
    ap.add_argument("--camera", metavar="URL", help="v4l2://0, file://..., sim://outcrop")
    ap.add_argument("--archive", type=Path, metavar="DIR", help="session archive folder")
    ap.add_argument("--mode", choices=MODES, help="zenoh mode")
    ap.add_argument("--listen", action="append", metavar="ENDPOINT", help="e.g. tcp/0.0.0.0:7447")
    ap.add_argument("--connect", action="append", metavar="ENDPOINT", help="a router or peer")
    ap.add_argument(
        "--insecure",
        action="store_true",
        help="allow clear-text endpoints beyond loopback (a lab bench, never the field)",
    )
    ap.add_argument(
        "--sim",
        action="store_true",
        help="a simulated rig to try the clients with: the PTU emulator on a pty, the "
        "simulated camera on a generated cliff, the approach magnified, archive in "
        "./out/rig (each overridable by the flags above or the config file)",
    )


SIM_PTU = "pty://?model=D46-17&time_scale=2"
SIM_CAMERA = "sim://world?seed=3&hfov=30"


def _simulated(cfg: Config) -> Config:
    """``--sim``: the simulated parts wherever neither a flag nor the config file chose one
    (a file's archive, PTU or camera is kept), and the approach magnified."""
    base = Config()
    camera = (
        cfg.camera if cfg.camera.url != base.camera.url else replace(cfg.camera, url=SIM_CAMERA)
    )
    return replace(
        cfg,
        ptu=SIM_PTU if cfg.ptu == base.ptu else cfg.ptu,
        archive=Path("out/rig") if cfg.archive == base.archive else cfg.archive,
        camera=camera,
        survey=replace(cfg.survey, simulate_approach=True),
    )


def _run_daemon(args: argparse.Namespace) -> int:
    try:
        cfg = load(args.config, rig=args.rig, ptu=args.ptu, archive=args.archive)
        if args.camera:
            cfg = replace(cfg, camera=replace(cfg.camera, url=args.camera))
        if args.sim:
            cfg = _simulated(cfg)
        z = cfg.zenoh
        cfg = validate(
            replace(
                cfg,
                zenoh=replace(
                    z,
                    mode=args.mode or z.mode,
                    listen=tuple(args.listen) if args.listen is not None else z.listen,
                    connect=tuple(args.connect) if args.connect is not None else z.connect,
                    insecure=args.insecure or z.insecure,
                ),
            )
        )
    except ValueError as exc:
        print(f"cyborgd: {exc}", file=sys.stderr)
        return 2
    try:
        return asyncio.run(run(cfg, ready_stream=route_zenoh_logs()))
    except (PtuError, CameraError, OSError, zenoh.ZError) as exc:
        print(f"cyborgd: {exc}", file=sys.stderr)
        return 1


def _analyze_parser(sub: argparse._SubParsersAction) -> None:
    ap = sub.add_parser(
        "analyze",
        help="find interest points in image files, folders or globs, on every core",
    )
    ap.add_argument(
        "images",
        nargs="*",
        metavar="INPUT",
        help="an image file, a folder (its images, recursively) or a quoted glob ('**' recurses)",
    )
    ap.add_argument(
        "--from",
        dest="from_file",
        metavar="FILE",
        help="also the inputs listed in FILE, one per line (# comments; -: standard input)",
    )
    ap.add_argument(
        "--out",
        type=Path,
        default=Path("out/analyze"),
        help="product folder, one sub-folder per image and summary.jsonl (default: %(default)s)",
    )
    ap.add_argument("--profile", choices=sorted(PROFILES), default="default")
    ap.add_argument("--top", type=int, default=None, metavar="N", help="number of interest points")
    add_aim_argument(ap, "default: the profile's (any)")
    add_settings_argument(ap, "the profile", default=[])
    ap.add_argument(
        "--downsample",
        type=float,
        default=None,
        metavar="F",
        help="reduce the image F times before analysis, as the seed did (4-8); "
        "default: the profile's working size",
    )
    ap.add_argument(
        "--products",
        choices=PRODUCTS,
        default="all",
        help="images written beside each result.json: all (default), overlay or none",
    )
    ap.add_argument(
        "--resume",
        action="store_true",
        help="keep the images whose folder already holds a complete result made with the "
        "same profile and parameters",
    )
    ap.add_argument(
        "--jobs",
        type=int,
        default=None,
        metavar="N",
        help="analysis processes (default: one per core)",
    )
    ap.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run on a Dask cluster (tcp://HOST:8786; the workers must see the same paths; "
        "needs the 'cluster' extra)",
    )
    ap.add_argument("--json", action="store_true", help="print one JSON object per image")


def _demo_parser(sub: argparse._SubParsersAction) -> None:
    ap = sub.add_parser("demo", help="generate an outcrop scene and analyse it with both profiles")
    ap.add_argument("--out", type=Path, default=Path("out/demo"))
    ap.add_argument("--seed", type=int, default=9)


def _emulator_parser(sub: argparse._SubParsersAction) -> None:
    ap = sub.add_parser(
        "ptu-emulator",
        help="run a PTU-46 emulator on a pseudo-terminal and print the path to open",
    )
    ap.add_argument("--model", choices=sorted(MODELS), default="D46-17")
    ap.add_argument(
        "--time-scale",
        type=float,
        default=1.0,
        metavar="X",
        help="emulated seconds per real second (default: %(default)s)",
    )
    ap.add_argument("--link", type=Path, help="also make this symlink to the pty (like /dev/ptu)")
    ap.add_argument(
        "--baud", type=int, default=9600, help="pace output like this line; 0: no pacing"
    )
    ap.add_argument("--banner", action="store_true", help="print a power-up banner first")
    ap.add_argument(
        "--tcp",
        metavar="HOST:PORT",
        help="also serve the line over TCP, as a PTU-E46 or a terminal server (ptu = tcp://...)",
    )
    ap.add_argument(
        "--fault",
        action="append",
        default=[],
        metavar="SPEC",
        help="inject a fault: action[:match[:nth[:seconds]]], "
        "action = garbage|drop|delay|hangup (repeatable)",
    )


def _router_parser(sub: argparse._SubParsersAction) -> None:
    ap = sub.add_parser(
        "router", help="run the field network's zenoh router (TLS, access list from users)"
    )
    ap.add_argument("--config", type=Path, required=True, help="router.toml (see docs/security.md)")


def _run_emulator(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    try:
        faults = [parse_fault(spec) for spec in args.fault]
        emulator = Ptu46Emulator(MODELS[args.model], time_scale=args.time_scale)
    except ValueError as exc:
        parser.error(str(exc))
    if not MODELS[args.model].verified:
        _LOGGER.warning("model %s: its numbers are inferred, not from a manual", args.model)
    server = PtyEmulatorServer(
        emulator,
        link=args.link,
        faults=faults,
        banner=BANNER if args.banner else None,
        baud=args.baud,
    )
    tcp = None
    if args.tcp:
        host, _, port = args.tcp.rpartition(":")
        if not host or not port.isdigit():
            parser.error(f"--tcp {args.tcp!r}: want HOST:PORT, e.g. 127.0.0.1:4001")
        tcp = (host, int(port))
    asyncio.run(serve(server, tcp))
    return 0


def main(argv: list[str] | None = None) -> int:
    """A closed stdout (``cyborgd analyze --json ... | head``) ends any command quietly, with
    the status a shell gives a command SIGPIPE ended (141), as ``cyborg`` does."""
    try:
        code = _main(argv)
        sys.stdout.flush()  # a closed pipe shows here, not in the interpreter's exit
    except BrokenPipeError:
        # Python's recipe: stdout at devnull, so the flush at exit finds nothing to write.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    return code


def _main(argv: list[str] | None) -> int:
    parser = argparse.ArgumentParser(prog="cyborgd", description=__doc__)
    parser.add_argument(
        "--version",
        action="version",
        version=f"%(prog)s {BUILD} (protocol {PROTOCOL_MAJOR}.{PROTOCOL_MINOR})",
    )
    parser.add_argument("-v", "--verbose", action="store_true")
    sub = parser.add_subparsers(dest="command", required=True)
    _run_parser(sub)
    _analyze_parser(sub)
    _demo_parser(sub)
    _emulator_parser(sub)
    _router_parser(sub)
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=logging.DEBUG
        if args.verbose
        else logging.INFO
        if args.command in ("run", "router")
        else logging.WARNING,
        format="%(levelname)s %(name)s: %(message)s",
    )
    # OpenCV and libpng print their own warnings for bad files; ours are one line each.
    quiet = cv2.utils.logging.LOG_LEVEL_SILENT
    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_INFO if args.verbose else quiet)
    if args.command == "router":
        return run_router(args.config)
    if args.command == "analyze":
        if args.downsample is not None and args.downsample <= 0:
            parser.error("--downsample must be > 0")
        try:
            params = with_settings(profile(args.profile), args.settings)
        except ValueError as exc:
            parser.error(f"--set: {exc}")
        if args.top is not None:
            if args.top < 1:
                parser.error("--top must be at least 1")
            params = params.replace(top_n=args.top)
        if args.aim is not None:
            params = params.replace(aim=args.aim)
        if args.jobs is not None and args.jobs < 1:
            parser.error("--jobs must be at least 1")
        if not args.images and args.from_file is None:
            parser.error("give an image, a folder or a glob, or --from FILE")
        # The science core is loaded only to analyse, never by the service.
        cli = importlib.import_module(".tools.analyze", __package__)
        inputs = list(args.images)
        if args.from_file is not None:
            try:
                inputs += cli.read_list(args.from_file)
            except (OSError, UnicodeDecodeError) as exc:
                parser.error(f"--from: cannot read {args.from_file}: {exc}")
        opts = cli.AnalyzeOptions(
            args.out,
            args.profile,
            params,
            args.downsample,
            args.json,
            args.jobs,
            args.products,
            args.resume,
            args.scheduler,
        )
        return cli.analyze_files(inputs, opts)
    if args.command == "run":
        return _run_daemon(args)
    if args.command == "ptu-emulator":
        return _run_emulator(args, parser)
    # The demo's scene generator is loaded only for the demo, never by the service.
    return importlib.import_module(".tools.reproduce", __package__).reproduce(args.out, args.seed)


if __name__ == "__main__":
    sys.exit(main())
