"""Plain commands for scripts: ``cyborg status | goto | survey | fetch | list | choose |
halt | take | release``, and ``cyborg call VERB FIELDS`` for any command of the protocol,
each printing one JSON object with ``--json``.

Exit status: 0 done; 1 the rig refused or failed (the JSON says why); 2 a bad request;
3 the rig is not reachable, or left the bus meanwhile (its liveliness token went); 130
interrupted (Ctrl-C: the survey the command started is cancelled and the control it took
released). Motion takes control when nobody holds it; from another client only with
``--take``.
"""

from __future__ import annotations

import argparse
import asyncio
import hashlib
import json
import sys
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

import zenoh

from cyborg.protocol.aims import add_aim_argument
from cyborg.protocol.messages import (
    REQUESTS,
    ArchiveGet,
    ArchiveList,
    ChooseTarget,
    Hello,
    InterestResult,
    PtuGoto,
    PtuHalt,
    PtuState,
    ReleaseControl,
    SurveyProgress,
    SurveyStart,
    SurveyStatus,
    TakeControl,
)
from cyborg.protocol.settings import add_settings_argument
from cyborg.protocol.version import PROTOCOL_MAJOR, PROTOCOL_MINOR

from .export import point_rows, to_csv, to_geojson
from .link import add_link_arguments, transport
from .rigclient import (
    ControlHeldError,
    RigClient,
    RigError,
    RigRefusedError,
    RigUnavailableError,
    run_station,
)

__all__ = ["register"]

UNREACHABLE = 3
INTERRUPTED = 130
Report = dict[str, Any]
Command = Callable[[RigClient, argparse.Namespace], Awaitable[tuple[Report, str]]]


def _acked(ack: Any) -> tuple[Report, str]:
    return {"ok": True, "result": ack.result, "detail": ack.detail}, ack.detail


async def _pose(client: RigClient, timeout: float = 2.0) -> PtuState | None:
    states = client.subscribe(client.keys.ptu_state, PtuState, maxsize=1)
    try:
        return await asyncio.wait_for(states.get(), timeout)
    except TimeoutError:
        return None


# -- the commands: each returns (the report for --json, the text for people) ----------------


async def _status(client: RigClient, args: argparse.Namespace) -> tuple[Report, str]:
    hello = await client.command(Hello(PROTOCOL_MAJOR, PROTOCOL_MINOR))
    status = await client.command(SurveyStatus())
    pose = await _pose(client)
    report: Report = {
        "ok": True,
        "rig": hello.rig,
        "protocol": f"{hello.major}.{hello.minor}",
        "build": hello.build,
        **status.to_body(),
        "ptu": pose.to_body() if pose else None,
    }
    ptu = (
        f"pan {pose.pan:+8.3f}  tilt {pose.tilt:+8.3f}  "
        f"{'moving' if pose.moving else 'still'}  link {pose.link}"
        if pose
        else "no state received"
    )
    station = f"{status.station} at {status.distance_m:g} m" if status.station else "-"
    lines = [
        f"rig {hello.rig} (cyborgd {hello.build}, protocol {hello.major}.{hello.minor}): "
        f"{status.state}",
        f"  PTU      {ptu}",
        f"  control  {status.controller or 'nobody'}",
        f"  station  {station}",
        f"  worker   pid {status.worker_pid}",
    ]
    if status.aim:  # a 2.5 rig: what the next station seeks unless told otherwise
        lines.insert(-1, f"  aim      {status.aim} (the next station's, unless --aim)")
    if status.last_error:
        lines.append(f"  error    {status.last_error}")
    return report, "\n".join(lines)


async def _goto(client: RigClient, args: argparse.Namespace) -> tuple[Report, str]:
    await client.ensure_control(args.take)
    states = client.subscribe(client.keys.ptu_state, PtuState, maxsize=1)
    report, text = _acked(await client.command(PtuGoto(args.pan, args.tilt)))
    if not args.wait:
        return report, text
    status = await client.command(SurveyStatus())
    step = status.ptu_step or PtuState.MAX_STEP  # the unit's own, or an older rig's bound
    async with asyncio.timeout(args.timeout):
        while True:
            s = await states.get()
            if not s.moving and abs(s.pan - args.pan) <= step and abs(s.tilt - args.tilt) <= step:
                break
    report |= {"pan": s.pan, "tilt": s.tilt}
    return report, f"at pan {s.pan:+.3f}, tilt {s.tilt:+.3f}"


async def _survey(client: RigClient, args: argparse.Namespace) -> tuple[Report, str]:
    await client.ensure_control(args.take)
    progress = client.subscribe(client.keys.progress, SurveyProgress)
    results = client.subscribe(client.keys.result, InterestResult)
    settings = None if args.settings is None else tuple(args.settings)
    request = SurveyStart(
        args.rows, args.cols, args.downsample, args.profile, settings=settings, aim=args.aim
    )

    def show(p: SurveyProgress) -> None:
        count = f" {p.done}/{p.total}" if p.total else ""
        eta = f", ETA {p.eta_s:.0f} s" if p.eta_s is not None else ""
        print(f"{p.station}: {p.stage}{count}{eta}", file=sys.stderr)

    result = await run_station(
        client, progress, results, request, timeout=args.timeout, on_progress=show
    )
    sought = f", aim {result.aim}" if result.aim else ""
    if args.aim and not result.aim:  # a rig older than protocol 2.5 ignores the field
        sought = ", the rig ranked for no aim (it predates aims of study)"
    lines = [f"station {result.station}: mosaic {result.width}x{result.height}{sought}"]
    for p in result.points:
        mark = "" if p.target else "  no further target"
        lines.append(
            f"  #{p.rank} score {p.score:5.2f}  pan {p.pan:+8.3f}  tilt {p.tilt:+7.3f}{mark}"
        )
        lines.append(f"     {p.why}")
    return {"ok": True, **result.to_body()}, "\n".join(lines)


async def _fetch(client: RigClient, args: argparse.Namespace) -> tuple[Report, str]:
    reply = await client.command(ArchiveGet(args.session, args.product))
    data = reply.data
    report: Report = {
        "ok": True,
        "session": args.session,
        "product": args.product,
        "bytes": len(data),
        "sha256": hashlib.sha256(data).hexdigest(),
    }
    if args.output == "-":
        sys.stdout.buffer.write(data)
        sys.stdout.flush()
        return report, ""
    out = Path(args.output or Path(args.product).name)
    out.write_bytes(data)
    report["path"] = str(out.resolve())
    return report, f"wrote {out} ({len(data)} bytes)"


async def _export(client: RigClient, args: argparse.Namespace) -> tuple[Report, str]:
    """Every interest point of a session, from its station manifests, as CSV or GeoJSON."""
    listing = await client.command(ArchiveList(args.session))
    manifests = []
    for product in listing.items:
        if product.count("/") == 1 and product.endswith("/manifest.json"):
            reply = await client.command(ArchiveGet(args.session, product))
            manifests.append(json.loads(reply.data))
    rows = point_rows(manifests)
    text = to_csv(rows) if args.format == "csv" else json.dumps(to_geojson(manifests), indent=1)
    out = Path(args.output or f"{args.session}.{args.format}")
    report: Report = {"ok": True, "session": args.session, "points": len(rows)}
    if args.output == "-":
        sys.stdout.write(text)
        return report, ""
    out.write_text(text)
    report["path"] = str(out.resolve())
    return report, f"wrote {out} ({len(rows)} points of {len(manifests)} stations)"


async def _report(client: RigClient, args: argparse.Namespace) -> tuple[Report, str]:
    """The session's report page as the rig wrote it (self-contained: images embedded)."""
    reply = await client.command(ArchiveGet(args.session, "report.html"))
    out = Path(args.out) / f"report-{args.session}.html"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_bytes(reply.data)
    report: Report = {"ok": True, "session": args.session, "path": str(out.resolve())}
    return report, f"wrote {out}: open it in a browser, or print it (A4)"


async def _list(client: RigClient, args: argparse.Namespace) -> tuple[Report, str]:
    listing = await client.command(ArchiveList(args.session))
    return {"ok": True, **listing.to_body()}, "\n".join(listing.items)


async def _choose(client: RigClient, args: argparse.Namespace) -> tuple[Report, str]:
    await client.ensure_control(args.take)
    return _acked(await client.command(ChooseTarget(args.station, args.rank)))


async def _halt(client: RigClient, args: argparse.Namespace) -> tuple[Report, str]:
    return _acked(await client.command(PtuHalt()))


async def _take(client: RigClient, args: argparse.Namespace) -> tuple[Report, str]:
    return _acked(await client.command(TakeControl()))


async def _release(client: RigClient, args: argparse.Namespace) -> tuple[Report, str]:
    return _acked(await client.command(ReleaseControl()))


async def _run(command: Command, args: argparse.Namespace) -> int:
    """One command, its outcome as an exit status; never a traceback for a rig's answer."""
    code = 1
    try:
        with RigClient.open(transport(args, "client"), args.rig, args.name) as client:
            try:
                async with client.on_bus(args.wait_rig):
                    report, text = await command(client, args)
                code = 0
            except asyncio.CancelledError:  # Ctrl-C: asyncio.run cancels this task once
                asyncio.current_task().uncancel()
                undone = await client.rollback()
                code, text = INTERRUPTED, "; ".join(["interrupted", *undone])
                report = {"ok": False, "error": text}
    except zenoh.ZError as exc:
        code, text = UNREACHABLE, f"cannot reach {', '.join(transport(args, 'client').connect)}"
        report = {"ok": False, "error": f"{text}: {exc}"}
    except RigUnavailableError as exc:
        code, text, report = UNREACHABLE, str(exc), {"ok": False, "error": str(exc)}
    except ControlHeldError as exc:
        text = f"{exc}; pass --take to take it over"
        report = {"ok": False, "result": "REJECTED", "error": text}
    except RigRefusedError as exc:
        text, report = str(exc), {"ok": False, "result": exc.ack.result, "error": exc.ack.detail}
    except RigError as exc:
        text, report = str(exc), {"ok": False, "error": str(exc)}
    except ValueError as exc:  # a request out of range, refused before it is sent
        code, text, report = 2, str(exc), {"ok": False, "error": str(exc)}
    except TimeoutError:
        text = f"gave up after {args.timeout:g} s"
        report = {"ok": False, "error": text}
    if args.json:
        print(json.dumps(report))
    elif code == 0 and text:
        print(text)
    if code:
        print(f"cyborg {args.command}: {text}", file=sys.stderr)
    return code


async def _call(client: RigClient, args: argparse.Namespace) -> tuple[Report, str]:
    """Any command, straight from the registry: a new command needs no new code here."""
    request = REQUESTS[args.verb]
    try:
        body = json.loads(args.fields)
    except json.JSONDecodeError as exc:
        raise ValueError(f"fields: not JSON: {exc}") from None
    if not isinstance(body, dict):
        raise ValueError("fields: a JSON object, e.g. {}")
    msg = request.from_body(body)
    if request.MOVES:
        await client.ensure_control(args.take)
    reply = await client.command(msg)
    fields = {k: v for k, v in reply.to_body().items() if not isinstance(v, bytes)}
    return {"ok": True, "kind": reply.KIND, **fields}, json.dumps(fields)


def register(sub: argparse._SubParsersAction) -> None:
    """Add the script commands to ``cyborg``'s parser."""

    def command(name: str, fn: Command, about: str, motion: bool = False) -> Any:
        p = sub.add_parser(name, help=about, description=about)
        add_link_arguments(p, "cli")
        p.add_argument("--json", action="store_true", help="print one JSON object")
        p.add_argument(
            "--wait-rig",
            type=float,
            default=5.0,
            metavar="S",
            help="how long to wait for the rig to appear on the bus (default 5 s)",
        )
        p.add_argument(
            "--timeout",
            type=float,
            default=300.0,
            metavar="S",
            help="how long to wait for the rig's answer or the station (default 300 s)",
        )
        if motion:
            p.add_argument("--take", action="store_true", help="take control from another client")
        p.set_defaults(run=lambda args: asyncio.run(_run(fn, args)))
        return p

    command("status", _status, "what the rig is doing, where the head points, who drives")
    goto = command("goto", _goto, "point the head at PAN TILT degrees", motion=True)
    goto.add_argument("pan", type=float)
    goto.add_argument("tilt", type=float)
    goto.add_argument("--wait", action="store_true", help="return once the head is there")
    survey = command("survey", _survey, "survey a station and print its interest points", True)
    survey.add_argument("--rows", type=int, help="mosaic rows (default: the rig's config)")
    survey.add_argument("--cols", type=int, help="mosaic columns")
    survey.add_argument("--downsample", type=float, help="tile reduction factor")
    survey.add_argument(
        "--profile",
        help="science profile, one the rig knows (see cyborgd analyze --help); "
        "default: the rig's survey.profile",
    )
    given = survey.add_mutually_exclusive_group()
    add_settings_argument(
        given,
        "the profile for this station",
        otherwise="the rig checks it before it moves; default: the rig's survey.settings",
    )
    given.add_argument(
        "--no-settings",
        action="store_const",
        const=[],
        dest="settings",
        help="none of the rig's configured survey.settings, the profile as it is",
    )
    add_aim_argument(
        survey,
        "default: the session's last station's aim, else the rig's survey.aim "
        "(--aim any: no preference)",
    )
    fetch = command("fetch", _fetch, "download one archived product")
    fetch.add_argument("session")
    fetch.add_argument("product", help="a path inside the session, e.g. st01-300m/mosaic.png")
    fetch.add_argument("-o", "--output", help="file to write ('-': stdout; default: its name)")
    export = command("export", _export, "a session's interest points as CSV or GeoJSON")
    export.add_argument("session")
    export.add_argument("--format", choices=("csv", "geojson"), default="csv")
    export.add_argument(
        "-o", "--output", help="file to write ('-': stdout; default SESSION.FORMAT)"
    )
    report = command("report", _report, "a session's report page (HTML, prints to A4)")
    report.add_argument("session")
    report.add_argument("--out", default=".", help="folder to write it in (default: here)")
    listing = command("list", _list, "archived sessions, or one session's products")
    listing.add_argument("session", nargs="?", default="")
    choose = command("choose", _choose, "choose a station's target: rank 1-3, or 0", True)
    choose.add_argument("station", help="the station id, e.g. 20261121-101500/st01-300m")
    choose.add_argument("rank", type=int, choices=range(4))
    command("halt", _halt, "stop the head (and any survey) now; needs no control")
    command("take", _take, "take control of the rig's motion")
    command("release", _release, "release control")
    call = command(
        "call",
        _call,
        "send any command of the protocol by its verb, fields as JSON; print the reply",
        motion=True,
    )
    call.add_argument("verb", choices=sorted(REQUESTS), metavar="VERB", help=", ".join(REQUESTS))
    call.add_argument("fields", nargs="?", default="{}", help='e.g. \'{"pan": 10, "tilt": -2}\'')
