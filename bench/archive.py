"""Archive-scale throughput of ``cyborgd analyze`` over real images, before vs after, same run.

*Before* is the command as commit ``--before`` ships it (``git archive``, run from a
temporary copy; by default the last commit with the sequential command): one process,
every product fsynced file by file. *After* is the working
tree's command, by default (one process per core) and with ``--jobs 1``; ``--products
none`` shows what the images cost to write. Every figure is the whole command's wall time
over the same N real images (Python's start-up and each process's included), in images/s,
and its CPU time per image (all its processes): on a machine other jobs load, wall time
shows the share of the cores it got, CPU time what each image costs.

The write share is timed apart, in one process, by the same loop on both trees
(``read_image``, ``analyze_image``, ``write_products`` with every product): the seconds spent
writing over the seconds of analysis plus writing.

Usage: ``python -m bench.archive [--images 200] [--share 40] [--rounds 1] [--before REV]
[--json]`` (``--data``: the real data folder, as ``bench.real``).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from io import BytesIO
from pathlib import Path

from bench.real import default_data_dir

ROOT = Path(__file__).resolve().parents[1]
SEQUENTIAL = "caa75057776123bd4e031585ed8009ab6b1f4f7f"
"""The last commit whose ``cyborgd analyze`` ran one image after another."""

_SPLIT = """
import json, sys, time
from pathlib import Path
from cyborg.daemon.vision.imageio import read_image
from cyborg.daemon.vision.job import analyze_image, write_products
from cyborg.daemon.vision.params import DEFAULT
try:
    from cyborg.daemon.vision.threads import single_thread
    single_thread()
except ImportError:
    pass
paths, out = sys.argv[1:-1], Path(sys.argv[-1])
analysis = write = 0.0
for k, path in enumerate(paths):
    image = read_image(path)
    t0 = time.perf_counter()
    bgr, res = analyze_image(image, DEFAULT)
    t1 = time.perf_counter()
    write_products(out / str(k), path, bgr, res, "default")
    t2 = time.perf_counter()
    if k:  # the first image loads (or compiles) what the rest reuse
        analysis += t1 - t0
        write += t2 - t1
print(json.dumps({"analysis_s": analysis, "write_s": write}))
"""


def real_images(data: Path, n: int) -> list[str]:
    """N images spread evenly over every set's sorted images."""
    every = sorted(str(p) for p in data.glob("*/images/*.png"))
    if not every:
        raise SystemExit(f"no real images under {data} (set CYBORG_REAL_DATA)")
    n = min(n, len(every))
    return [every[k * len(every) // n] for k in range(n)]


def previous_tree(into: Path, revision: str) -> Path:
    """A commit's packages as ``cyborg.*`` under ``into`` (for PYTHONPATH)."""
    archive = subprocess.run(
        ["git", "archive", "--format=tar", revision, "daemon", "protocol"],
        cwd=ROOT,
        capture_output=True,
        check=True,
    ).stdout
    with tarfile.open(fileobj=BytesIO(archive)) as tar:
        tar.extractall(into / "cyborg", filter="data")
    return into


def _env(tree: Path | None) -> dict[str, str]:
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    if tree is not None:
        env["PYTHONPATH"] = str(tree)
    return env


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run_command(tree: Path | None, listing: Path, out: Path, *flags: str) -> tuple[float, float]:
    """Wall and CPU seconds (its processes' user + system time) of one ``cyborgd analyze``
    over the listed images (the old command has no --from)."""
    images = listing.read_text().split()
    args = [*images] if tree is not None else ["--from", str(listing)]
    cpu = _children_cpu()
    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-m", "cyborg.daemon", "analyze", *args, "--out", str(out), *flags],
        env=_env(tree),
        capture_output=True,
        text=True,
        check=False,
        cwd=out.parent,
    )
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"cyborgd analyze failed ({proc.returncode}): {proc.stderr[-2000:]}")
    return wall, _children_cpu() - cpu


def write_share(tree: Path | None, images: list[str], out: Path) -> dict[str, float]:
    """Analysis and write seconds of the in-process loop on one tree (``_SPLIT``)."""
    proc = subprocess.run(
        [sys.executable, "-c", _SPLIT, *images, str(out)],
        env=_env(tree),
        capture_output=True,
        text=True,
        check=True,
        cwd=out.parent,
    )
    times = json.loads(proc.stdout.strip().splitlines()[-1])
    times["share"] = times["write_s"] / (times["analysis_s"] + times["write_s"])
    return times


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--images", type=int, default=200)
    ap.add_argument("--share", type=int, default=40, help="images for the write-share loop")
    ap.add_argument("--rounds", type=int, default=1, help="runs of each command (median)")
    ap.add_argument("--data", type=Path, default=default_data_dir())
    ap.add_argument(
        "--before", default=SEQUENTIAL, metavar="REV", help="the commit to compare with"
    )
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    images = real_images(args.data, args.images)
    runs = {
        "before: sequential": (True, ()),
        "after: --jobs 1": (False, ("--jobs", "1")),
        f"after: default ({os.cpu_count()} processes)": (False, ()),
        "after: default, --products none": (False, ("--products", "none")),
    }
    walls: dict[str, list[float]] = {name: [] for name in runs}
    cpus: dict[str, list[float]] = {name: [] for name in runs}
    with tempfile.TemporaryDirectory(prefix="bench-archive-") as tmp:
        work = Path(tmp)
        old = previous_tree(work / "before", args.before)
        listing = work / "images.txt"
        listing.write_text("\n".join(images) + "\n")
        warm = work / "warm.txt"
        warm.write_text(images[0] + "\n")
        for tree in (old, None):  # compile or load each tree's kernels before any timing
            run_command(tree, warm, work / "warm", "--json")
        for r in range(args.rounds):
            for k, (name, (before, flags)) in enumerate(runs.items()):
                out = work / f"out-{r}-{k}"
                wall, cpu = run_command(old if before else None, listing, out, *flags)
                walls[name].append(wall)
                cpus[name].append(cpu)
                print(f"{name}: {wall:.1f} s, CPU {cpu:.1f} s", file=sys.stderr)
        sample = images[: args.share + 1]
        share = {
            "before": write_share(old, sample, work / "split-before"),
            "after": write_share(None, sample, work / "split-after"),
        }
    rates = {name: len(images) / statistics.median(w) for name, w in walls.items()}
    cpu_ms = {name: 1e3 * statistics.median(c) / len(images) for name, c in cpus.items()}
    base = rates["before: sequential"]
    report = {
        "images": len(images),
        "cores": os.cpu_count(),
        "load_average": os.getloadavg()[0],
        "images_per_s": {k: round(v, 2) for k, v in rates.items()},
        "speedup_vs_before": {k: round(v / base, 2) for k, v in rates.items()},
        "cpu_ms_per_image": {k: round(v, 1) for k, v in cpu_ms.items()},
        "write_share": {k: {n: round(x, 3) for n, x in v.items()} for k, v in share.items()},
    }
    if args.json:
        print(json.dumps(report, indent=2))
        return 0
    print(
        f"cyborgd analyze over {len(images)} real images, {os.cpu_count()} cores, same run "
        f"(load average {report['load_average']:.1f} at the end: other jobs share the cores)"
    )
    print(f"{'command':44} {'images/s':>9} {'vs before':>10} {'CPU ms/image':>13}")
    for name, rate in rates.items():
        print(f"{name:44} {rate:9.2f} {rate / base:9.2f}x {cpu_ms[name]:13.0f}")
    print(f"write share of analysis + write (in-process loop, {args.share} images):")
    for name, s in share.items():
        print(
            f"  {name:7} analysis {s['analysis_s']:6.1f} s, write {s['write_s']:6.1f} s, "
            f"write {100 * s['share']:.0f} %"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
