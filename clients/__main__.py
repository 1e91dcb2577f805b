"""``cyborg``: clients of the rig's bus."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from cyborg.protocol.keys import check_client
from cyborg.protocol.version import BUILD, PROTOCOL_MAJOR, PROTOCOL_MINOR

from . import cli
from .demo import run_demo
from .keypad.app import run_keypad
from .link import add_link_arguments, transport
from .replay import run_replay


def _operator(args: argparse.Namespace) -> int:
    """The console needs aiohttp (the ``operator`` extra); the rig and its keypad do not."""
    try:
        from .operator.main import run_operator  # noqa: PLC0415
    except ModuleNotFoundError as exc:
        print(
            f"cyborg operator: {exc.name} is missing: pip install 'cyborg-astrobiologist[operator]'"
        )
        return 2
    return run_operator(args)


CLOSED_PIPE = 141
"""A reader that went away (``cyborg list | head -1``): the status a shell gives a command
SIGPIPE ended (128 + 13), without a traceback."""


def main(argv: list[str] | None = None) -> int:
    """Every subcommand, ended quietly by a closed stdout or Ctrl-C wherever it is."""
    try:
        code = _main(argv)
        sys.stdout.flush()  # a closed pipe shows here, not in the interpreter's exit
    except BrokenPipeError:
        # Python's recipe: stdout at devnull, so the flush at exit finds nothing to write.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return CLOSED_PIPE
    except KeyboardInterrupt:  # outside a command's own handling (bus commands exit 130 too)
        print("cyborg: interrupted", file=sys.stderr)
        return cli.INTERRUPTED
    return code


def _main(argv: list[str] | None) -> int:
    parser = argparse.ArgumentParser(prog="cyborg", description=__doc__)
    parser.add_argument(
        "--version",
        action="version",
        version=f"%(prog)s {BUILD} (protocol {PROTOCOL_MAJOR}.{PROTOCOL_MINOR})",
    )
    parser.add_argument(
        "--json",
        action="store_true",
        dest="json_first",
        help="as the script commands' own --json, given before the command",
    )
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="a simulated field day: daemon, emulator, three stations")
    demo.add_argument("--out", type=Path, default=Path("out/demo"))
    demo.add_argument("--time-scale", type=float, default=4.0, help="PTU emulator speed-up")
    demo.add_argument("--seed", type=int, default=3, help="which generated cliff")
    demo.set_defaults(run=lambda a: run_demo(a.out, a.time_scale, a.seed))
    keypad = sub.add_parser(
        "keypad", help="full-screen client for the arm's keyboard and head-mounted display"
    )
    add_link_arguments(keypad, "keypad")
    keypad.set_defaults(run=run_keypad)
    operator = sub.add_parser(
        "operator", help="the remote operator's web console, served on 127.0.0.1"
    )
    add_link_arguments(operator, "operator")
    operator.add_argument("--host", default="127.0.0.1", help="address the page listens on")
    operator.add_argument("--port", type=int, default=8080, help="its port (0: any free one)")
    operator.add_argument(
        "--public-host",
        action="append",
        default=[],
        metavar="NAME[:PORT]",
        help="a name browsers use to reach the console through a reverse proxy (repeatable "
        "or comma-separated); requests naming any other host are refused",
    )
    operator.set_defaults(run=_operator)
    replay = sub.add_parser(
        "replay", help="publish a recorded session (session.mcap) on the bus, at its pace"
    )
    replay.add_argument("session", help="a session folder of the archive, or its session.mcap")
    add_link_arguments(replay, "replay")
    replay.add_argument("--speed", type=float, default=1.0, help="x the recorded pace")
    replay.add_argument(
        "--once",
        action="store_true",
        help="exit at the recording's end (default: go on answering, as the rig stood then, "
        "until stopped)",
    )
    replay.add_argument("--as-rig", dest="rig_override", help="rig name (default: recorded)")
    replay.add_argument(
        "--listen", action="append", metavar="ENDPOINT", help="serve clients here, as a rig"
    )
    replay.set_defaults(run=run_replay)
    cli.register(sub)
    args = parser.parse_args(argv)
    if args.json_first:  # `cyborg --json status` as `cyborg status --json`
        if not hasattr(args, "json"):
            parser.error(f"--json: cyborg {args.command} has no JSON output")
        args.json = True
    if hasattr(args, "env_connect"):  # a bus client: refuse a bad name or link up front
        try:
            check_client(args.name)
            transport(args, "peer")
        except (ValueError, OSError) as exc:
            parser.error(str(exc))
    return args.run(args)


if __name__ == "__main__":
    sys.exit(main())
