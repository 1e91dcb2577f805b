"""Paired CPU-time A/B of two trees' science on the same images, image by image.

On a shared machine a whole-run figure moves by 10-30 % from one run to the next (``bench.stages``
gave 62 and 95 ms an image for one tree within the hour), so two trees timed one after the other
cannot be told apart by a 10 % change. Here one analysis process per tree stays up, each image
goes to both in turn (the order alternating), three times, and each tree keeps its fastest CPU
time for it: both meet the same load within a fraction of a second, and the per-image ratio
cancels what the machine did. Each process runs its own tree's code and its own venv (its
``.venv/bin/python``, or ``--python``) on one thread of each native pool, as the rig runs.

Usage: ``python -m bench.ab --before DIR [--after DIR] [--profile default] [--step 2]
[--seed-scenes 20] [--repeats 3]``. ``DIR`` is a checkout (``git worktree add``) with a venv.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from bench.real import default_data_dir

_SERVE = """
import sys, time
sys.path.insert(0, ".")
from bench.real import list_sets, read_manifest
from cyborg.daemon.sim.regimes import seed_cliff
from cyborg.daemon.vision.imageio import read_image
from cyborg.daemon.vision.job import analyze_image
from cyborg.daemon.vision.params import PROFILES
from cyborg.daemon.vision.threads import single_thread
from pathlib import Path
single_thread()
data, profile, step, seeds = Path(sys.argv[1]), sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
params = PROFILES[profile]
images = [read_image(data / s / "images" / n) for s in list_sets(data)
          for n, _ in read_manifest(data / s)[::step]] if step else []
images += [seed_cliff(s).image for s in range(seeds)]
for image in images[:3] + images[-3:]:  # compiled kernels loaded, caches warm
    analyze_image(image, params)
print(len(images), flush=True)
for line in sys.stdin:
    t0 = time.process_time()
    analyze_image(images[int(line)], params)
    print((time.process_time() - t0) * 1e3, flush=True)
"""


def _serve(tree: Path, python: str, argv: list[str]) -> subprocess.Popen[str]:
    env = dict(os.environ, PYTHONPATH=str(tree))
    return subprocess.Popen(
        [python, "-c", _SERVE, *argv], cwd=tree, env=env, text=True,
        stdin=subprocess.PIPE, stdout=subprocess.PIPE,
    )  # fmt: skip


def paired(procs: list[subprocess.Popen[str]], repeats: int) -> np.ndarray:
    """(trees, images) fastest CPU ms of each image in each process, timed in turn."""
    counts = {int(p.stdout.readline()) for p in procs}  # type: ignore[union-attr]
    if len(counts) != 1:
        raise SystemExit(f"the trees see different images: {sorted(counts)}")
    n = counts.pop()
    best = np.full((len(procs), n), np.inf)
    for rep in range(repeats):
        for k in range(n):
            order = range(len(procs)) if (k + rep) % 2 else reversed(range(len(procs)))
            for i in order:
                procs[i].stdin.write(f"{k}\n")  # type: ignore[union-attr]
                procs[i].stdin.flush()  # type: ignore[union-attr]
                took = float(procs[i].stdout.readline())  # type: ignore[union-attr]
                best[i, k] = min(best[i, k], took)
    return best


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", type=Path, required=True, help="the other tree (with .venv)")
    ap.add_argument("--after", type=Path, default=Path(__file__).resolve().parents[1])
    ap.add_argument("--python", default="", help="the before tree's python (default: its .venv)")
    ap.add_argument("--profile", default="default")
    ap.add_argument("--step", type=int, default=2, help="every Nth real image (0: none)")
    ap.add_argument("--seed-scenes", type=int, default=20, help="the seed's 108x192 cliffs")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)
    data = default_data_dir()
    step = args.step if any(data.glob("*/manifest.tsv")) else 0
    if not step:
        print(f"ab: no real images in {data}; the seed's cliffs only")
    serve = [str(data), args.profile, str(step), str(args.seed_scenes)]
    before = _serve(args.before, args.python or str(args.before / ".venv/bin/python"), serve)
    after = _serve(args.after, sys.executable, serve)
    try:
        best = paired([before, after], args.repeats)
    finally:
        for p in (before, after):
            p.stdin.close()  # type: ignore[union-attr]
            p.wait()
    n = best.shape[1]
    seeds = n - args.seed_scenes
    groups = [("real images", slice(0, seeds)), ("the seed's 108x192", slice(seeds, n))]
    print(
        f"paired CPU ms per image, {args.profile}, the fastest of {args.repeats} in turn; "
        f"after: {args.after}, before: {args.before}"
    )
    for name, part in groups:
        a, b = best[0, part], best[1, part]
        if not len(a):
            continue
        ratio = b / a
        q1, q2, q3 = np.percentile(ratio, (25, 50, 75))
        print(
            f"{name} ({len(a)}): before median {np.median(a):.2f} mean {a.mean():.2f}; "
            f"after median {np.median(b):.2f} mean {b.mean():.2f}; "
            f"after/before per image median {q2:.3f} (quartiles {q1:.3f}-{q3:.3f})"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
