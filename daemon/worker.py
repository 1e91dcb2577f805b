"""The vision worker: the science core in its own process, restarted when it dies.

A separate process keeps the event loop (PTU, bus, live frames) responsive while a
mosaic is analysed, and a crash in native image code cannot take the daemon with it.
It is started with the ``spawn`` method: forking a process that has a zenoh session
open hangs the child (see the stack notes).

The contract is typed: a call sends a :class:`Job` (a picklable value, e.g. the frozen
dataclass ``vision.contract.AnalysisJob``) and gets back an instance of the type the job
promises (``Job.returns``); anything else is a :class:`WorkerError`.
"""

from __future__ import annotations

import asyncio
import contextlib
import ctypes
import itertools
import logging
import multiprocessing as mp
import os
import signal
import sys
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from typing import Any, ClassVar, Protocol, Self, TypeVar, runtime_checkable

__all__ = ["Job", "VisionWorker", "WorkerCrashedError", "WorkerError"]

_LOGGER = logging.getLogger(__name__)


class WorkerError(RuntimeError):
    """The job raised inside the worker; the text is the worker's one-line reason."""


class WorkerCrashedError(WorkerError):
    """The worker process died during the job (killed, out of memory, native crash)."""


_PR_SET_PDEATHSIG = 1


def _die_with(parent: int) -> None:
    """Have the kernel kill this process when the daemon dies, however it dies (a SIGKILL,
    an OOM kill): an orphan would go on computing for nobody and could race a restarted
    daemon's clean-up of ``.analysis.partial``. Linux only; elsewhere the worker exits at
    its next read of the closed pipe."""
    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    if os.getppid() != parent:  # the daemon died before the request took effect
        os._exit(0)


R = TypeVar("R")
R_co = TypeVar("R_co", covariant=True)


@runtime_checkable
class Job(Protocol[R_co]):
    """A typed request: a picklable value whose :meth:`run`, called in the worker process,
    returns an instance of :attr:`returns`. The daemon imports the job's module, so it
    stays light: ``run`` imports the heavy code (the science core) it needs."""

    returns: ClassVar[type]

    def run(self) -> R_co: ...


@dataclass(frozen=True)
class _Call:
    """One job sent to the worker; ``id`` ties the reply to the call that is waiting."""

    id: int
    job: Job[Any]


@dataclass(frozen=True)
class _Reply:
    """The worker's answer to call ``id``: its value, or the error's one line and traceback."""

    id: int
    value: Any = None
    error: str = ""
    traceback: str = ""


def _serve(conn: Connection, parent: int) -> None:
    """Worker main loop: run calls until the pipe closes or the daemon dies.

    The daemon owns the worker's lifetime: a Ctrl-C or a SIGTERM sent to the whole process
    group (a terminal, ``timeout``, systemd's control-group kill) must not kill it
    mid-job; it exits when the daemon closes the pipe, and with the daemon.
    """
    _die_with(parent)
    from .vision.threads import single_thread  # noqa: PLC0415 - the daemon stays light

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    single_thread()  # before the science core loads its libraries
    try:  # so that the first station is not the one that loads (or compiles) the kernels
        from .vision.kernels import warm  # noqa: PLC0415

        warm()
    except Exception:  # a job meets the same fault and reports it; the worker stays up
        _LOGGER.exception("vision worker: warming the science core failed")
    while True:
        try:
            call: _Call = conn.recv()
        except (EOFError, OSError):
            return
        try:
            reply = _Reply(call.id, value=_run(call.job))
        except Exception as exc:  # reported to the daemon, which decides
            reply = _Reply(
                call.id, error=f"{type(exc).__name__}: {exc}", traceback=traceback.format_exc()
            )
        try:
            conn.send(reply)
        except OSError:  # the daemon is gone (BrokenPipe): nobody to tell
            return


def _run(job: Job[R]) -> R:
    """Run ``job``; a value other than the type it promised is the job's error."""
    value = job.run()
    if not isinstance(value, job.returns):
        raise TypeError(
            f"{type(job).__name__} returned {type(value).__name__}, not {job.returns.__name__}"
        )
    return value


class VisionWorker:
    """One worker process; :meth:`call` runs a :class:`Job` in it.
    An async context manager: started on entry, stopped on exit."""

    def __init__(self, on_restart: Callable[[str], None] | None = None) -> None:
        self._ctx = mp.get_context("spawn")
        self._proc: Any = None
        self._conn: Connection | None = None
        self._lock = asyncio.Lock()
        self._ids = itertools.count(1)
        self._closing = False
        self.restarts = 0
        self.on_restart = on_restart

    @property
    def pid(self) -> int:
        return self._proc.pid if self._proc is not None and self._proc.is_alive() else 0

    def start(self) -> None:
        parent, child = self._ctx.Pipe()
        proc = self._ctx.Process(
            target=_serve, args=(child, os.getpid()), name="cyborgd-vision", daemon=True
        )
        proc.start()
        child.close()
        self._proc, self._conn = proc, parent
        asyncio.get_running_loop().add_reader(proc.sentinel, self._on_exit, proc)
        _LOGGER.info("vision worker started, pid %d", proc.pid)

    def _on_exit(self, proc: Any) -> None:
        asyncio.get_running_loop().remove_reader(proc.sentinel)
        proc.join(0)
        if self._closing or proc is not self._proc:
            return
        self.restarts += 1
        text = f"vision worker pid {proc.pid} died (exit code {proc.exitcode})"
        if self._conn is not None and not self._lock.locked():
            self._conn.close()  # else the job in flight finds the death and closes it
        self.start()
        text += f"; restarted as pid {self._proc.pid}"
        _LOGGER.warning("%s", text)
        if self.on_restart is not None:
            self.on_restart(text)

    async def call(self, job: Job[R]) -> R:
        """Run ``job`` in the worker and return its result; one job at a time.

        Cancelling the call kills the worker and starts a fresh one before the cancellation
        goes on: the job stops computing and writing at once (so its caller can clean up
        what it wrote), and no late reply can reach the next call. A restart costs less
        than the rest of an analysis nobody wants (``make bench-field``).

        Raises WorkerCrashedError if the process dies meanwhile, WorkerError if ``job`` is no
        :class:`Job`, raised, or returned another type than it promised.
        """
        if isinstance(job, type) or not isinstance(job, Job):
            raise WorkerError(f"not a worker job: {type(job).__name__} (want run() and returns)")
        async with self._lock:
            proc, conn = self._proc, self._conn
            if proc is None or conn is None:
                raise WorkerCrashedError("vision worker is not running")
            call = _Call(next(self._ids), job)
            roundtrip = asyncio.ensure_future(asyncio.to_thread(self._roundtrip, proc, conn, call))
            try:
                return await asyncio.shield(roundtrip)
            except WorkerCrashedError:
                conn.close()
                raise
            except asyncio.CancelledError:
                self._replace(proc)
                await asyncio.wait([roundtrip])  # its thread sees the death and returns
                conn.close()
                raise

    def _replace(self, proc: Any) -> None:
        """Start a fresh worker, then kill ``proc`` (not a crash: no restart is counted)."""
        self._proc = self._conn = None  # so that _on_exit knows this death was ours
        if not self._closing:
            self.start()
        proc.kill()
        _LOGGER.info("vision worker pid %d stopped: its job was cancelled", proc.pid)

    @staticmethod
    def _roundtrip(proc: Any, conn: Connection, call: _Call) -> Any:
        try:
            conn.send(call)
            while True:
                ready = wait([conn, proc.sentinel])
                if conn in ready:
                    reply: _Reply = conn.recv()
                    if reply.id == call.id:
                        break
                    _LOGGER.warning("discarded a stray reply to call %d", reply.id)
                elif proc.sentinel in ready:
                    raise EOFError
        except (EOFError, OSError):
            raise WorkerCrashedError(
                f"vision worker pid {proc.pid} died during the job (exit code {proc.exitcode})"
            ) from None
        if not reply.error:
            return reply.value
        _LOGGER.debug("worker traceback:\n%s", reply.traceback)
        raise WorkerError(reply.error)

    async def __aenter__(self) -> Self:
        self.start()
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.aclose()

    async def aclose(self, timeout: float = 5.0) -> None:
        """Close the pipe (the worker exits at its next read), then make sure it is gone;
        the waiting happens off the event loop, at most ``timeout`` twice."""
        self._closing = True
        proc = self._proc
        if proc is None:
            return
        with contextlib.suppress(Exception):
            asyncio.get_running_loop().remove_reader(proc.sentinel)
        if self._conn is not None:
            self._conn.close()
        await asyncio.to_thread(proc.join, timeout)
        if proc.is_alive():
            proc.terminate()
            await asyncio.to_thread(proc.join, timeout)
        self._proc = self._conn = None
