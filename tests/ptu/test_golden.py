"""Golden byte transcripts: the emulator's exact output and the codec's reading of it.

Each file in ``golden/`` is a session: ``> 'bytes'`` sent to the unit, ``< 'bytes'`` one
line the unit wrote, ``@ t`` the emulated clock moving to ``t`` seconds. The wording
follows the PTU-D46 manual where the manual gives it.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from cyborg.daemon.ptu.emulator import Ptu46Emulator
from cyborg.daemon.ptu.wire import parse_reply, split_limit_events

GOLDEN = sorted((Path(__file__).parent / "golden").glob("*.txt"))


def _steps(path: Path) -> list[tuple[str, object, list[str]]]:
    steps: list[tuple[str, object, list[str]]] = []
    for raw in path.read_text().splitlines():
        if not raw or raw.startswith("#"):
            continue
        tag, arg = raw[0], raw[1:].strip()
        if tag == ">":
            steps.append((">", ast.literal_eval(arg), []))
        elif tag == "@":
            steps.append(("@", float(arg), []))
        elif tag == "<":
            steps[-1][2].append(ast.literal_eval(arg))
        else:
            raise ValueError(f"{path.name}: bad line {raw!r}")
    return steps


@pytest.mark.parametrize("path", GOLDEN, ids=lambda p: p.stem)
def test_emulator_matches_transcript(path: Path) -> None:
    now = [0.0]
    emu = Ptu46Emulator(clock=lambda: now[0])
    for tag, arg, expected in _steps(path):
        if tag == ">":
            got = emu.receive(str(arg).encode("ascii"))
        else:
            now[0] = float(arg)  # type: ignore[arg-type]
            got = emu.poll()
        assert got.decode("ascii").splitlines(keepends=True) == expected, (tag, arg)


@pytest.mark.parametrize("path", GOLDEN, ids=lambda p: p.stem)
def test_codec_reads_every_reply(path: Path) -> None:
    for _, _, lines in _steps(path):
        for line in lines:
            assert line.endswith("\r\n")
            text = line[:-2]
            rest, events = split_limit_events(text)
            if events and not rest:
                continue
            echo = None if text[0] in "*!" else text.split(" ", 1)[0]
            reply = parse_reply(text, echo)
            assert reply is not None, text
            assert reply.ok == (rest.lstrip(echo or "").strip()[0] == "*")


def test_golden_files_exist() -> None:
    assert len(GOLDEN) >= 8
