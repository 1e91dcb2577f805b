"""``cyborgd analyze`` at archive scale, as real processes: folders, globs and lists, every
core, progress on a terminal only, --products, --resume after a kill, summary.jsonl, --aim,
and the same results from a real Dask scheduler with two worker processes."""

from __future__ import annotations

import io
import json
import os
import pty
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import cv2
import pytest

from bench import archive as archive_bench
from cyborg.daemon.sim.scene import outcrop_scene
from cyborg.daemon.tools.progress import Progress
from tests.tools.test_analyze_cli import cyborgd

ROOT = Path(__file__).resolve().parents[2]
_COMMAND = (sys.executable, "-m", "cyborg.daemon", "analyze")


def _env(*paths: Path) -> dict[str, str]:
    return {"PYTHONPATH": os.pathsep.join([*map(str, paths), str(ROOT)]), "PATH": "/usr/bin:/bin"}


def _scene(path: Path, seed: int) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(path), outcrop_scene(seed, (96, 128), n_targets=1).image)
    return path


def _summary(out: Path) -> list[dict]:
    return [json.loads(line) for line in (out / "summary.jsonl").read_text().splitlines()]


def _wait_for_lines(summary: Path, run: subprocess.Popen, count: int) -> None:
    deadline = time.monotonic() + 240
    while run.poll() is None and time.monotonic() < deadline:
        if summary.exists() and len(summary.read_text().splitlines()) >= count:
            return
        time.sleep(0.05)


def _without_timings(folder: Path) -> dict:
    doc = json.loads((Path(folder) / "result.json").read_text())
    doc.pop("timing_ms")
    return doc


def _assert_same_results(a: Path, b: Path) -> None:
    """Two runs over the same inputs: the same points, result.json but for its timings,
    and byte-identical images."""
    lines_a, lines_b = _summary(a), _summary(b)
    assert [(x["image"], x["points"]) for x in lines_a] == [
        (x["image"], x["points"]) for x in lines_b
    ]
    for x, y in zip(lines_a, lines_b, strict=True):
        fa, fb = a / Path(x["folder"]).name, b / Path(y["folder"]).name
        assert fa.name == fb.name and _without_timings(fa) == _without_timings(fb)
        names = sorted(p.name for p in fa.glob("*.png"))
        assert names == sorted(p.name for p in fb.glob("*.png")) and names
        for name in names:
            assert (fa / name).read_bytes() == (fb / name).read_bytes(), name


@pytest.fixture
def archive(tmp_path: Path) -> list[Path]:
    """Inputs of every kind; returns the images in the order the command must take them."""
    tree = [
        _scene(tmp_path / "archive/day1/x.png", 1),
        _scene(tmp_path / "archive/day2/deep/a.png", 2),
        _scene(tmp_path / "archive/day2/x.png", 3),
    ]
    (tmp_path / "archive/day1/notes.txt").write_text("not an image\n")
    globbed = [_scene(tmp_path / "loose/b.png", 4), _scene(tmp_path / "loose/c.png", 5)]
    listed = _scene(tmp_path / "elsewhere/d.png", 6)
    (tmp_path / "list.txt").write_text(f"# today's extra\n\n{listed}\n")
    return [*sorted(tree), *globbed, listed]


def test_folders_globs_and_lists_in_order_on_every_core(tmp_path, archive):
    inputs = [str(tmp_path / "archive"), str(tmp_path / "loose/*.png"), "--from", "list.txt"]
    many = cyborgd("analyze", *inputs, "--json", "--out", "many", "--jobs", "2", cwd=tmp_path)
    assert many.returncode == 0, many.stderr
    assert many.stderr == "", "a pipe gets nothing but results"
    assert [json.loads(x)["image"] for x in many.stdout.splitlines()] == list(map(str, archive))
    lines = _summary(tmp_path / "many")
    assert [x["image"] for x in lines] == list(map(str, archive))
    assert [Path(x["folder"]).name for x in lines] == ["x", "a", "x-2", "b", "c", "d"]
    for line in lines:
        assert list(line) == ["image", "folder", "status", "width", "height", "points", "timing_ms"]
        assert line["status"] == "done" and set(line["timing_ms"]) == {"analysis", "write"}
        assert line["points"] and all(
            list(p) == ["rank", "x", "y", "score", "target"] for p in line["points"]
        )
    one = cyborgd("analyze", *inputs, "--out", "one", "--jobs", "1", cwd=tmp_path)
    assert one.returncode == 0, one.stderr
    _assert_same_results(tmp_path / "many", tmp_path / "one")


def test_inputs_without_images_are_errors_in_their_place(tmp_path, archive):
    (tmp_path / "empty").mkdir()
    proc = cyborgd("analyze", "empty", "nothing/*.png", str(archive[0]), "--out", "o", cwd=tmp_path)
    assert proc.returncode == 1
    assert proc.stderr.splitlines() == [
        "cyborgd analyze: empty: no image files in it",
        "cyborgd analyze: nothing/*.png: no image matches",
    ]
    assert [x["status"] for x in _summary(tmp_path / "o")] == ["failed", "failed", "done"]


def test_products_none_and_overlay(tmp_path, archive):
    for mode, files in (("none", {"result.json"}), ("overlay", {"result.json", "overlay.png"})):
        proc = cyborgd("analyze", str(archive[3]), "--products", mode, "--out", mode, cwd=tmp_path)
        assert proc.returncode == 0, proc.stderr
        folder = tmp_path / mode / "b"
        assert {p.name for p in folder.iterdir()} == files
        doc = json.loads((folder / "result.json").read_text())
        assert set(doc["products"]) == {name.removesuffix(".png") for name in files} - {
            "result.json"
        }
        assert doc["points"]


def test_resume_keeps_complete_folders_and_redoes_the_rest(tmp_path, archive):
    images = list(map(str, archive[3:]))
    assert cyborgd("analyze", *images, "--out", "o", cwd=tmp_path).returncode == 0
    marks = {p.parent.name: p.stat().st_mtime_ns for p in (tmp_path / "o").glob("*/result.json")}
    (tmp_path / "o/c/result.json").unlink()  # as a crash while writing c's products leaves it
    again = cyborgd("analyze", *images, "--out", "o", "--resume", "--json", cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    assert [x["status"] for x in _summary(tmp_path / "o")] == ["skipped", "done", "skipped"]
    for name in ("b", "d"):
        assert (tmp_path / "o" / name / "result.json").stat().st_mtime_ns == marks[name]
    assert len(again.stdout.splitlines()) == 3
    changed = cyborgd("analyze", *images, "--out", "o", "--resume", "--set", "blur=8", cwd=tmp_path)
    assert changed.returncode == 0, changed.stderr
    assert [x["status"] for x in _summary(tmp_path / "o")] == ["done"] * 3
    more = cyborgd("analyze", *images, "--out", "o", "--resume", "--products", "none", cwd=tmp_path)
    assert [x["status"] for x in _summary(tmp_path / "o")] == ["done"] * 3, more.stderr


def test_a_killed_run_leaves_only_complete_folders_and_resumes(tmp_path):
    images = [str(_scene(tmp_path / f"in/{k:02d}.png", 10 + k)) for k in range(12)]
    run = subprocess.Popen(
        [*_COMMAND, *images, "--out", "o", "--jobs", "2"],
        cwd=tmp_path,
        env=_env(),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,  # its processes form one group, killed together
    )
    try:
        _wait_for_lines(tmp_path / "o/summary.jsonl", run, 2)
    finally:
        if run.poll() is None:
            os.killpg(run.pid, signal.SIGKILL)
        run.wait()
    kept = _summary(tmp_path / "o")
    complete = []
    for folder in (tmp_path / "o").iterdir():
        if (folder / "result.json").exists():
            doc = json.loads((folder / "result.json").read_text())
            assert all((folder / name).stat().st_size > 0 for name in doc["products"].values())
            complete.append(folder.name)
    assert {Path(x["folder"]).name for x in kept} <= set(complete)
    resumed = cyborgd("analyze", *images, "--out", "o", "--resume", cwd=tmp_path)
    assert resumed.returncode == 0, resumed.stderr
    statuses = {Path(x["folder"]).name: x["status"] for x in _summary(tmp_path / "o")}
    assert len(statuses) == 12 and {statuses[name] for name in complete} == {"skipped"}
    assert set(statuses.values()) <= {"skipped", "done"}


def test_ctrl_c_stops_every_process_and_says_how_to_resume(tmp_path):
    images = [str(_scene(tmp_path / f"in/{k:02d}.png", 30 + k)) for k in range(12)]
    run = subprocess.Popen(
        [*_COMMAND, *images, "--out", "o", "--jobs", "2"],
        cwd=tmp_path,
        env=_env(),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    try:
        _wait_for_lines(tmp_path / "o/summary.jsonl", run, 1)
        os.killpg(run.pid, signal.SIGINT)  # a terminal's Ctrl-C reaches the whole group
        _, err = run.communicate(timeout=120)
    finally:
        if run.poll() is None:
            os.killpg(run.pid, signal.SIGKILL)
            run.wait()
    assert run.returncode == 130, err
    assert "interrupted" in err and "--resume" in err and "Traceback" not in err
    assert _group_ends(run.pid), "an analysis process outlived the command"


def _group_ends(group: int) -> bool:
    """Whether every process of the group has ended (killed after a minute otherwise)."""
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            os.killpg(group, 0)
        except ProcessLookupError:
            return True
        time.sleep(0.1)
    os.killpg(group, signal.SIGKILL)
    return False


def _read_all(fd: int) -> str:
    chunks = []
    while True:
        try:
            data = os.read(fd, 4096)
        except OSError:  # the terminal's other end closed
            break
        if not data:
            break
        chunks.append(data)
    return b"".join(chunks).decode()


def test_progress_on_a_terminal(tmp_path, archive):
    master, slave = pty.openpty()
    try:
        proc = subprocess.Popen(
            [*_COMMAND, *map(str, archive[3:]), "--json"],
            cwd=tmp_path,
            env=_env(),
            stdout=subprocess.PIPE,
            stderr=slave,
        )
        os.close(slave)
        stdout, _ = proc.communicate(timeout=240)
        screen = _read_all(master)
    finally:
        os.close(master)
    assert proc.returncode == 0
    assert len(stdout.splitlines()) == 3 and b"images" not in stdout
    assert "3/3 images" in screen and "/s, ETA 0:00" in screen
    assert "\r\x1b[K" in screen and screen.endswith("\n")


def test_progress_line_from_a_clock():
    now = [0.0]
    screen = io.StringIO()
    progress = Progress(4, screen, interval=1.0, clock=lambda: now[0])
    assert progress.line() == "0/4 images"
    now[0] = 2.0
    progress.advance()
    now[0] = 2.5
    progress.advance()  # within the interval: not drawn
    assert screen.getvalue() == "\r\x1b[K1/4 images, 0.5/s, ETA 0:06"
    progress.clear()
    progress.advance()  # drawn at once after a clear
    assert screen.getvalue().endswith("\r\x1b[K3/4 images, 1.2/s, ETA 0:01")
    progress.close()
    assert screen.getvalue().endswith("\n")


def test_aim_and_usage_errors(tmp_path, archive):
    proc = cyborgd(
        "analyze", str(archive[3]), "--aim", "no-vegetation+dark", "--out", "o", cwd=tmp_path
    )
    assert proc.returncode == 0, proc.stderr
    doc = json.loads((tmp_path / "o/b/result.json").read_text())
    assert doc["params"]["aim"] == "dark+no-vegetation"
    bad = cyborgd("analyze", "x.png", "--aim", "wet", cwd=tmp_path)
    assert bad.returncode == 2 and "unknown 'wet'" in bad.stderr
    bad = cyborgd("analyze", "x.png", "--jobs", "0", cwd=tmp_path)
    assert bad.returncode == 2 and "--jobs must be at least 1" in bad.stderr
    bad = cyborgd("analyze", "--from", "missing.txt", cwd=tmp_path)
    assert bad.returncode == 2 and "--from: cannot read missing.txt" in bad.stderr
    assert cyborgd("analyze", "x.png", "--products", "some", cwd=tmp_path).returncode == 2


def test_without_dask_the_error_says_how_to_install(tmp_path, archive):
    shadow = tmp_path / "no-dask/distributed"
    shadow.mkdir(parents=True)
    (shadow / "__init__.py").write_text("raise ImportError('No module named distributed')\n")
    proc = subprocess.run(
        [*_COMMAND, str(archive[3]), "--scheduler", "tcp://127.0.0.1:1", "--out", "o"],
        cwd=tmp_path,
        env=_env(shadow.parent),
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert proc.returncode == 1
    assert proc.stderr.strip() == (
        "cyborgd analyze: --scheduler needs dask.distributed, which is not installed: "
        "pip install 'cyborg-astrobiologist[cluster]'"
    )


@pytest.fixture
def dask_cluster(tmp_path: Path) -> Iterator[str]:
    """A real Dask scheduler and two single-thread worker processes on loopback ports the
    kernel picked; yields the scheduler's address."""
    dask = Path(sys.executable).parent / "dask"
    info = tmp_path / "scheduler.json"
    here = ["--host", "127.0.0.1", "--no-dashboard", "--scheduler-file", str(info)]
    scheduler = subprocess.Popen(
        [str(dask), "scheduler", "--port", "0", *here],
        cwd=tmp_path,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    workers = None
    try:
        deadline = time.monotonic() + 120
        address = ""
        while not address and time.monotonic() < deadline:
            assert scheduler.poll() is None, "the scheduler exited"
            time.sleep(0.1)
            try:
                address = json.loads(info.read_text())["address"]
            except (OSError, ValueError):  # not there yet, or being written
                continue
        workers = subprocess.Popen(
            [str(dask), "worker", "--nworkers", "2", "--nthreads", "1", *here],
            cwd=tmp_path,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        yield address
    finally:
        for proc in (workers, scheduler):
            if proc is not None:
                proc.send_signal(signal.SIGINT)
        for proc in (workers, scheduler):
            if proc is not None:
                try:
                    proc.wait(timeout=30)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.wait()


def test_a_dask_cluster_gives_the_local_results(tmp_path, archive, dask_cluster):
    inputs = [str(tmp_path / "archive"), str(tmp_path / "loose/*.png"), "--from", "list.txt"]
    remote = cyborgd(
        "analyze", *inputs, "--scheduler", dask_cluster, "--json", "--out", "remote", cwd=tmp_path
    )
    assert remote.returncode == 0, remote.stderr
    assert [json.loads(x)["image"] for x in remote.stdout.splitlines()] == list(map(str, archive))
    local = cyborgd("analyze", *inputs, "--out", "local", cwd=tmp_path)
    assert local.returncode == 0, local.stderr
    _assert_same_results(tmp_path / "remote", tmp_path / "local")


def test_the_archive_bench_runs_on_a_few_images(tmp_path, capsys):
    for k in range(3):
        _scene(tmp_path / f"data/set/images/{k}.png", 50 + k)
    flags = ["--images", "3", "--share", "2", "--data", str(tmp_path / "data"), "--json"]
    assert archive_bench.main([*flags, "--before", "HEAD"]) == 0  # a shallow clone has HEAD
    report = json.loads(capsys.readouterr().out)
    assert report["images"] == 3 and len(report["images_per_s"]) == 4
    assert set(report["write_share"]) == {"before", "after"}
    assert all(0 < s["share"] < 1 for s in report["write_share"].values())
