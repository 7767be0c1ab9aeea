r"""Fair faces outside this process: the task, and ``fair_shape(jobs=N, face_timeout=S)``.

The faces of a shape are independent until the rebuild, so each selected face can be
faired in another process.  A face crosses a process boundary only as bytes, written
with ``BinTools`` (OCCT's binary format: every double bit for bit, the location and the
trim included); :func:`fair_face_task` runs the same per-face pipeline as the serial
path (trim classification, search, OCCT's deviation check) and sends back plain data:
the status, the message, the faired core :class:`~cq_fairing.BSplineSurface` and the
measures.  No OCCT object crosses a process.  The caller builds the OCCT face from that
surface, so the results are the same as in one process.

An engine is any object with ``run(tasks, done)`` and ``close()``:
:class:`ProcessFaces` runs the tasks on the standard library's
:class:`concurrent.futures.ProcessPoolExecutor`; :class:`cq_fairing.batch.DaskFaces`
on a Dask cluster.

:class:`ProcessFaces` and a time limit: a face still running ``timeout`` seconds after
its worker started it is reported ``'failed'`` ("time limit S s exceeded; kept the
original") and its worker is killed (``SIGKILL``: the memory and CPU it held are
released at once; it writes no files).  The executor then gives up its other running
faces; they are run again on a fresh one, not counted against them.  A worker that
dies by itself (a crash inside OCCT, the kernel's OOM killer) fails every face the
executor was running: each of those faces is run once more, alone, and reported
``'failed'`` ("the worker process fairing this face died 2 times") when its worker dies
again.

Workers are started with the ``spawn`` method (a fresh interpreter; no OCCT state or
threads are inherited), so a script calling ``fair_shape(jobs=...)`` at top level must
guard its entry point with ``if __name__ == "__main__":``, as for any
:mod:`multiprocessing` code.  Workers ignore SIGINT; Ctrl-C stops the parent, which
kills them on its way out.
"""

import io
import multiprocessing
import os
import signal
from collections import deque
from concurrent import futures
from concurrent.futures.process import BrokenProcessPool
from dataclasses import fields
from time import monotonic

from OCP.BinTools import BinTools
from OCP.TopoDS import TopoDS, TopoDS_Shape

from ..errors import FairingError
from .face_tasks import fair_one_face

__all__ = ["fair_face_task", "face_to_bytes", "face_from_bytes", "ProcessFaces", "ATTEMPTS"]

#: Runs of a face whose worker died under it before the face is reported failed.
ATTEMPTS = 2
_LOCAL_FIELDS = ("face", "original")
_starts = None   # in a worker of ProcessFaces: where each task announces its start


def face_to_bytes(face):
    """The face in OCCT's binary BRep format (exact doubles, location and trim)."""
    stream = io.BytesIO()
    BinTools.Write_s(face, stream)
    return stream.getvalue()


def face_from_bytes(data):
    """Inverse of :func:`face_to_bytes`."""
    shape = TopoDS_Shape()
    BinTools.Read_s(shape, io.BytesIO(data))
    return TopoDS.Face_s(shape)


def fair_face_task(index, data, options, tag=None):
    """Fair the face ``data`` (:func:`face_to_bytes`) with ``fair_face(**options)``.

    Returns
    -------
    dict
        The fields of its :class:`~cq_fairing.occ.FaceFairReport` but ``face`` and
        ``original`` (OCCT objects stay in the process that owns the shape).  Per-face
        failures are in the status (see :func:`~cq_fairing.occ.face_tasks.fair_one_face`);
        any other exception is a bug and propagates to the caller.
    """
    if _starts is not None:
        _starts.put((tag, os.getpid()))
    report = fair_one_face(index, face_from_bytes(data), options)
    return {f.name: getattr(report, f.name) for f in fields(report)
            if f.name not in _LOCAL_FIELDS}


def _worker_init(starts):
    global _starts
    _starts = starts
    signal.signal(signal.SIGINT, signal.SIG_IGN)


class ProcessFaces:
    """Fair faces in ``jobs`` worker processes, with an optional per-face time limit.

    Parameters
    ----------
    jobs : int
        Worker processes (at most one per face waiting).
    timeout : float or None
        Seconds a face may take, counted from its start in a worker.
    """

    def __init__(self, jobs, timeout):
        self.jobs, self.timeout = jobs, timeout
        self._context = multiprocessing.get_context("spawn")
        self._executor = self._starts = None
        self._runs = 0
        self._busy = {}        # tag -> pid of the worker running it
        self._started = {}     # tag -> when its start was seen
        self._any_start = False

    def close(self):
        """Stop the workers: those still running a face (an interrupted run) by SIGKILL."""
        for pid in self._busy.values():
            _kill(pid)
        self._busy = {}
        self._shutdown()

    def run(self, tasks, done):
        """Fair ``tasks`` = ``[(index, face, options)]``; ``done(index, outcome)`` each.

        ``outcome`` is ``("ok", fields)`` (:func:`fair_face_task`) or ``("failed",
        message)`` for a face over the time limit or whose worker died twice.  An
        exception raised in a worker outside the per-face isolation is raised here.

        Raises
        ------
        FairingError
            The workers die before starting any face (a script without the
            ``__main__`` guard).
        """
        self._runs += 1
        waiting = deque((index, face_to_bytes(face), options) for index, face, options in tasks)
        running, deaths = {}, {}
        workers = min(self.jobs, len(waiting))
        while waiting or running:
            executor = self._ready(workers)
            while waiting and len(running) < workers and not _suspect(running, deaths) \
                    and not (running and waiting[0][0] in deaths):
                index, data, options = waiting.popleft()
                future = executor.submit(fair_face_task, index, data, options,
                                         (self._runs, index))
                running[future] = (index, data, options)
            finished, _ = futures.wait(running, timeout=self._wait_time(),
                                       return_when=futures.FIRST_COMPLETED)
            self._note_starts()
            broken = [f for f in finished if isinstance(f.exception(), BrokenProcessPool)]
            for future in finished:
                if future not in broken:
                    index = running.pop(future)[0]
                    self._busy.pop((self._runs, index), None)
                    done(index, ("ok", future.result()))
            if broken:
                self._recover(running, waiting, deaths, done)
            else:
                self._enforce(running, waiting, done)

    # -- the time limit ------------------------------------------------------------------
    def _note_starts(self):
        """Read the workers' start messages; ``{tag: deadline}`` of the faces running."""
        while self._starts is not None and not self._starts.empty():
            tag, pid = self._starts.get()
            if tag[0] == self._runs:
                self._busy[tag] = pid
                self._started.setdefault(tag, monotonic())
                self._any_start = True
        if self.timeout is None:
            return {}
        return {tag: self._started[tag] + self.timeout for tag in self._busy}

    def _wait_time(self):
        deadlines = self._note_starts()
        if not deadlines:
            return None if self.timeout is None else 0.2   # a start may arrive any moment
        return max(0.0, min(deadlines.values()) - monotonic())

    def _enforce(self, running, waiting, done):
        """Kill the workers of faces over the time limit; run their neighbours again."""
        late = [tag for tag, deadline in self._note_starts().items() if monotonic() > deadline]
        if not late:
            return
        for tag in late:
            _kill(self._busy.pop(tag))
            index = tag[1]
            done(index, ("failed", f"time limit {self.timeout:g} s exceeded; kept the original"))
            future = next(f for f, task in running.items() if task[0] == index)
            del running[future]
        futures.wait(running)                  # the executor gives up the others
        for future, task in running.items():
            if future.exception() is None:
                done(task[0], ("ok", future.result()))
            else:
                waiting.appendleft(task)       # not their fault: not counted
        running.clear()
        self._busy = {}
        self._shutdown()

    # -- workers that die ----------------------------------------------------------------
    def _recover(self, running, waiting, deaths, done):
        """The executor lost a worker: count a death against each face it was running
        and run them again, or report those that died twice."""
        if not self._any_start:
            self._shutdown()
            raise FairingError(
                "a worker process could not start; a script calling fair_shape(jobs=...) "
                "must guard its entry point with if __name__ == '__main__'; or use jobs=1 "
                "without face_timeout.")
        for task in running.values():
            index = task[0]
            deaths[index] = deaths.get(index, 0) + 1
            if deaths[index] >= ATTEMPTS:
                done(index, ("failed", f"the worker process fairing this face died "
                                       f"{ATTEMPTS} times; kept the original"))
            else:
                waiting.appendleft(task)
        running.clear()
        self._busy = {}
        self._shutdown()

    def _ready(self, workers):
        if self._executor is None:
            self._starts = self._context.SimpleQueue()
            self._started = {}
            self._executor = futures.ProcessPoolExecutor(
                workers, mp_context=self._context, initializer=_worker_init,
                initargs=(self._starts,))
        return self._executor

    def _shutdown(self):
        if self._executor is not None:
            self._executor.shutdown(wait=True, cancel_futures=True)
            self._starts.close()
            self._executor = self._starts = None


def _suspect(running, deaths):
    """True while a face whose worker died runs: it runs alone, so a second death is
    its own."""
    return any(task[0] in deaths for task in running.values())


def _kill(pid):
    try:
        os.kill(pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
