"""Where ``default``'s time goes: CPU milliseconds per image by stage, on real images and the
seed's mosaic.

``bench.real`` gives one CPU time per image and ``bench.speed`` four coarse stages; a lever is
chosen by the stage that costs. Each function the pipeline calls by name (``pipeline``'s and
``aims``'s module-level names: the shadow gate, texture, the segmentations, the interest map,
the peaks, the explanations...) is timed with ``time.process_time`` while the whole analysis
runs as the rig runs it (``analyze_image``, one thread of each native pool); a stage that
calls another counts it too (``_segment_hue`` holds the hue's ``segment_plane``; ``aim_points``
holds ``find_points``). CPU time, so the machine's other work does not count; compare two
trees on the same machine in the same hour, and expect a few per cent of noise under load.

Usage: ``python -m bench.stages [--profile default] [--per-set 6] [--seed-runs 50]``.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import defaultdict
from types import ModuleType

import numpy as np

from bench.real import default_data_dir, list_sets, read_manifest
from cyborg.daemon.sim.regimes import seed_cliff
from cyborg.daemon.vision import aims, pipeline
from cyborg.daemon.vision.imageio import read_image
from cyborg.daemon.vision.job import analyze_image
from cyborg.daemon.vision.params import PROFILES
from cyborg.daemon.vision.threads import single_thread


def _timed(module: ModuleType, name: str, spent: dict[str, float]) -> None:
    """``module.name`` replaced by itself timed into ``spent[name]`` (seconds)."""
    fn = getattr(module, name)

    def run(*args: object, **kwargs: object) -> object:
        t0 = time.process_time()
        try:
            return fn(*args, **kwargs)
        finally:
            spent[name] += time.process_time() - t0

    setattr(module, name, run)


def _stages(spent: dict[str, float]) -> None:
    """Time every stage the pipeline and the aims call by name (callables of theirs from
    the science core, but not the dataclasses and the analysis itself)."""
    for module in (pipeline, aims):
        for name, value in list(vars(module).items()):
            own = getattr(value, "__module__", "") or ""
            if (
                callable(value)
                and not isinstance(value, type)
                and own.startswith("cyborg.daemon.vision")
                and name != "analyze"
                and not (module is aims and name in vars(pipeline))
            ):
                _timed(module, name, spent)


def real_sample(per_set: int) -> list[np.ndarray]:
    """``per_set`` images of each real set, evenly spaced through its manifest."""
    data = default_data_dir()
    images = []
    for name in list_sets(data):
        rows = read_manifest(data / name)
        step = max(1, len(rows) // per_set)
        images += [read_image(data / name / "images" / n) for n, _ in rows[::step][:per_set]]
    return images


def breakdown(
    images: list[np.ndarray], profile: str, spent: dict[str, float]
) -> tuple[float, dict[str, float]]:
    """(CPU ms per image, CPU ms per image by stage) of the stages timed into ``spent``
    (:func:`_stages`), after a warming run of the first images."""
    params = PROFILES[profile]
    for image in images[:3]:
        analyze_image(image, params)
    spent.clear()
    t0 = time.process_time()
    for image in images:
        analyze_image(image, params)
    total = (time.process_time() - t0) * 1e3 / len(images)
    return total, {k: v * 1e3 / len(images) for k, v in spent.items()}


def _print(label: str, total: float, stages: dict[str, float]) -> None:
    print(f"{label}: {total:.2f} CPU ms per image")
    for name, ms in sorted(stages.items(), key=lambda kv: -kv[1]):
        if ms >= 0.005:
            print(f"  {name:22s} {ms:7.2f} ms {100 * ms / total:5.1f} %")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--profile", default="default", choices=sorted(PROFILES))
    ap.add_argument("--per-set", type=int, default=6, help="real images per set (0: none)")
    ap.add_argument("--seed-runs", type=int, default=50, help="runs on the seed's mosaic")
    args = ap.parse_args(argv)
    single_thread()  # as the rig's analysis processes run
    real = real_sample(args.per_set) if args.per_set > 0 else []
    seed = [seed_cliff(0).image] * args.seed_runs
    spent: dict[str, float] = defaultdict(float)
    _stages(spent)
    for label, images in ((f"{len(real)} real images", real), ("seed's 108x192", seed)):
        if images:
            _print(f"{args.profile}, {label}", *breakdown(images, args.profile, spent))
    return 0


if __name__ == "__main__":
    sys.exit(main())
