r"""Fair faces in worker processes: ``fair_shape(jobs=N, face_timeout=S)``.

The faces of a shape are independent until the rebuild, so each selected face can be
faired in its own process.  A worker receives one face at a time, serialized with
``BinTools`` (OCCT's binary format: every double bit for bit, the location and the
trim included), runs the same per-face pipeline as the serial path (trim
classification, search, OCCT's deviation check) and sends back plain data: the status,
the message, the faired core :class:`~cq_fairing.BSplineSurface` and the measures.  The
parent builds the OCCT face from that surface, so the results are the same as with
``jobs=1``.

A face still running ``face_timeout`` seconds after it was handed to a worker is marked
``'failed'`` ("time limit S s exceeded; kept the original") and its worker is killed
(``SIGKILL``: the memory and CPU it held are released at once; it writes no files) and
replaced.  A worker that dies by itself (a crash inside OCCT, the kernel's OOM killer)
costs only its face, reported the same way.

Workers are started with the ``spawn`` method (a fresh interpreter; no OCCT state or
threads are inherited), so a script calling ``fair_shape(jobs=...)`` at top level must
guard its entry point with ``if __name__ == "__main__":``, as for any
:mod:`multiprocessing` code.  Workers ignore SIGINT; Ctrl-C stops the parent, which
kills them on its way out.
"""

import io
import multiprocessing
import signal
import time
from collections import deque
from dataclasses import fields
from multiprocessing.connection import wait

from OCP.BinTools import BinTools
from OCP.TopoDS import TopoDS, TopoDS_Shape

from ..errors import FairingError

__all__ = ["FacePool"]

_LOCAL_FIELDS = ("face", "original")


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


def _serve(conn):
    """Worker loop: ``(index, face bytes, options)`` in, ``("ok", fields)`` out."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    from .shapes import fair_one_face

    conn.send(("ready", None))
    while True:
        task = conn.recv()
        if task is None:
            return
        index, data, options = task
        try:
            report = fair_one_face(index, face_from_bytes(data), options)
        except Exception as exc:  # not a per-face failure: re-raised in the parent
            conn.send(("raise", _picklable(exc)))
            continue
        conn.send(("ok", {f.name: getattr(report, f.name) for f in fields(report)
                          if f.name not in _LOCAL_FIELDS}))


def _picklable(exc):
    import pickle

    try:
        pickle.loads(pickle.dumps(exc))
        return exc
    except Exception:  # an exception type that does not survive pickling
        return RuntimeError(f"{type(exc).__name__}: {exc}")


class _Worker:
    def __init__(self, context):
        self.conn, child = context.Pipe()
        self.process = context.Process(target=_serve, args=(child,), daemon=True)
        self.process.start()
        child.close()
        self.ready = False
        self.task = None          # (index, deadline) while busy

    def kill(self):
        self.process.kill()
        self.process.join()
        self.conn.close()


class FacePool:
    """Worker processes that fair faces, with an optional per-face time limit.

    Parameters
    ----------
    jobs : int
        Number of worker processes (at most one per pending face is started).
    timeout : float or None
        Seconds a face may take in its worker, counted from the hand-over.
    """

    def __init__(self, jobs, timeout):
        self.jobs, self.timeout = jobs, timeout
        self._context = multiprocessing.get_context("spawn")
        self._workers = []

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    def close(self):
        """Stop every worker (idle ones politely, busy ones by SIGKILL)."""
        for worker in self._workers:
            if worker.task is None and worker.process.is_alive():
                try:
                    worker.conn.send(None)
                except OSError:
                    pass
                worker.process.join(timeout=5)
            worker.kill()
        self._workers = []

    def run(self, tasks, done):
        """Fair ``tasks`` = ``[(index, face, options)]``; ``done(index, outcome)`` each.

        ``outcome`` is ``("ok", fields)`` (the report's fields but ``face`` and
        ``original``) or ``("failed", message)`` for a face that exceeded the time limit
        or whose worker died.  An exception raised in a worker outside the per-face
        isolation is raised here.
        """
        pending = deque((index, face_to_bytes(face), options) for index, face, options in tasks)
        while len(self._workers) < min(self.jobs, len(pending)):
            self._workers.append(_Worker(self._context))
        while pending or any(w.task for w in self._workers):
            self._hand_out(pending)
            self._collect(done, pending)

    def _hand_out(self, pending):
        for worker in self._workers:
            if worker.ready and worker.task is None and pending:
                index, data, options = pending.popleft()
                deadline = None if self.timeout is None else time.monotonic() + self.timeout
                worker.conn.send((index, data, options))
                worker.task = (index, deadline)

    def _collect(self, done, pending):
        ready = wait([w.conn for w in self._workers], timeout=self._wait_time())
        for worker in list(self._workers):
            if worker.conn in ready:
                self._receive(worker, done, pending)
            elif worker.task and worker.task[1] is not None and time.monotonic() > worker.task[1]:
                self._replace(worker, pending)
                done(worker.task[0], ("failed", f"time limit {self.timeout:g} s exceeded; "
                                                "kept the original"))

    def _wait_time(self):
        deadlines = [w.task[1] for w in self._workers if w.task and w.task[1] is not None]
        return None if not deadlines else max(0.0, min(deadlines) - time.monotonic())

    def _receive(self, worker, done, pending):
        try:
            kind, payload = worker.conn.recv()
        except (EOFError, OSError):
            if not worker.ready:
                self.close()
                raise FairingError(
                    f"a worker process could not start (exit code {worker.process.exitcode}); "
                    "a script calling fair_shape(jobs=...) must guard its entry point with "
                    "if __name__ == '__main__'; or use jobs=1 without face_timeout.") from None
            self._replace(worker, pending)
            if worker.task:
                done(worker.task[0], ("failed", "the worker process fairing this face "
                                                f"died (exit code {worker.process.exitcode}); "
                                                "kept the original"))
            return
        if kind == "ready":
            worker.ready = True
            return
        index, worker.task = worker.task[0], None
        if kind == "raise":
            raise payload
        done(index, (kind, payload))

    def _replace(self, worker, pending):
        """Kill ``worker``; start a fresh one if faces are still waiting."""
        worker.kill()
        self._workers.remove(worker)
        if pending:
            self._workers.append(_Worker(self._context))
