r"""Fair many models on a Dask cluster: the engine of ``cq-fairing batch``.

Each model is one Dask task (:func:`fair_model_task`), and each of its faces' first
fits is one more (:class:`DaskFaces`, submitted from the model's task), so one large
model spreads over every worker.  The model's task receives the input file's bytes,
reads them, fairs the model with :func:`~cq_fairing.occ.fair_shape` exactly as
``cq-fairing fair`` does (the faces that meet along whole borders are solved together
inside it, so a join region is never split), and returns the output file's bytes and
the report.  A face goes to its task as ``BinTools`` bytes and comes back as plain data
(:mod:`cq_fairing.occ.engine`); no OCCT object crosses a process, and the results are
the same as in one process for any number of workers.  The client writes every file
(atomically, read back and checked: :func:`~cq_fairing.occ.io.write_model_bytes`), so
the workers need no shared file system.

Fault tolerance is Dask's: a task whose worker dies (killed, out of memory) is run
again on another worker; the scheduler's ``distributed.scheduler.allowed-failures``
(set to ``ATTEMPTS - 1`` for the local cluster; set it on a scheduler of your own, e.g.
``DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES=1``) decides when it gives up
(``KilledWorker``): a face is then reported ``'failed'`` and keeps its original, a
model is reported failed, and the others go on.  The retries are counted from the
scheduler's record of each task (``TaskState.suspicious``) and reported per model.

Progress travels as Dask events (``Client.log_event`` on the workers,
``Client.subscribe_topic`` here) and is drawn with ``rich``.

This module needs ``pip install "cq-fairing[dask]"``; nothing else in the package
imports it.
"""

import hashlib
import logging
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import dask
from dask.base import tokenize
from distributed import Client, LocalCluster, as_completed, get_client, rejoin, secede
from distributed.scheduler import KilledWorker

from .errors import FileFormatError, InvalidInputError
from .occ.engine import ATTEMPTS, face_to_bytes, fair_face_task
from .shape_report import shape_report

__all__ = ["Settings", "DaskFaces", "fair_model", "fair_model_task", "open_cluster",
           "run_models", "sha256", "PROGRESS_TOPIC"]

PROGRESS_TOPIC = "cq-fairing-progress"

#: Dask's settings for the local cluster's worker processes, over Dask's own: without
#: the ``MALLOC_TRIM_THRESHOLD_=65536`` that Dask puts in a worker's environment (its
#: ``distributed.nanny.pre-spawn-environ``), which makes glibc give freed memory back
#: to the system at every ``free`` of more than 64 kB; the fairing's numpy temporaries
#: then cost page faults, about 30 % more wall time on testtoler (one BLAS thread per
#: worker, Dask's other default there, stays).
WORKER_ENVIRON = {"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}


@dataclass(frozen=True)
class Settings:
    """How every model of a batch is faired (``cq-fairing fair``'s options).

    ``tol`` is in model units; without it ``rel_tol`` times each model's bounding-box
    diagonal.  The other fields are ``fair_shape``'s options of the same names.
    """

    tol: float = None
    rel_tol: float = 1e-3
    method: str = "wavelet"
    objective: str = None
    borders: str = None
    joins: str = "smooth"
    angle_tol: float = 1.0
    target_degree: tuple = None
    boundary: str = "free"
    grading: str = "auto"
    convert: bool = False

    def as_dict(self):
        """The settings as plain data (what a model's report records for ``--resume``)."""
        return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items()}


def sha256(path):
    """Hex SHA-256 of a file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


# -- the faces of one model on the cluster ---------------------------------------------------
class DaskFaces:
    """An engine for ``fair_shape(engine=...)``: each face one Dask task.

    Parameters
    ----------
    label : str
        Names the tasks (``cq-fairing-face-<label>-<index>-<token>``).
    in_task : bool
        True inside a Dask task: the task leaves the worker's thread pool while it
        waits for its faces (``secede``/``rejoin``), so they can run there.

    Attributes
    ----------
    retries : int
        Face runs lost with a worker that died, over every :meth:`run`.
    """

    def __init__(self, label, in_task=True):
        self.label, self.in_task = label, in_task
        self.retries = 0

    def close(self):
        """Nothing to release: the cluster outlives a model."""

    def run(self, tasks, done):
        """Fair ``tasks`` = ``[(index, face, options)]``; ``done(index, outcome)`` each,
        as :meth:`cq_fairing.occ.engine.ProcessFaces.run` does."""
        client = get_client()
        futures = {}
        for index, face, options in tasks:
            data = face_to_bytes(face)
            key = f"cq-fairing-face-{self.label}-{index}-{tokenize(data, options)}"
            futures[client.submit(fair_face_task, index, data, options, key=key)] = index
        if self.in_task:
            secede()
        try:
            for future in as_completed(futures):
                done(futures[future], _outcome(future))
            self.retries += _lost_runs(client, [future.key for future in futures])
        finally:
            for future in futures:
                future.release()
            if self.in_task:
                rejoin()


def _outcome(future):
    try:
        return "ok", future.result()
    except KilledWorker as exc:
        return "failed", (f"the worker fairing this face died {exc.allowed_failures + 1} "
                          "times; kept the original")


def _lost_runs(client, keys):
    """How many runs of the tasks ``keys`` were lost with a worker that died (the
    scheduler's count per task; the tasks must still be held)."""
    def count(dask_scheduler, keys):   # nested: pickled by value, runs on the scheduler
        return sum(dask_scheduler.tasks[key].suspicious for key in keys
                   if key in dask_scheduler.tasks)
    return client.run_on_scheduler(count, keys=keys)


# -- one model -------------------------------------------------------------------------------
def fair_model(name, data, settings, output_name, engine=None, progress=None):
    """Fair the model file ``data`` as ``cq-fairing fair`` does and return the result.

    Parameters
    ----------
    name : str
        The input's path, as the report names it (its suffix gives the format).
    data : bytes
        The input file.
    settings : Settings
    output_name : str
        The output's path, as the report names it (``.step``/``.stp`` or ``.brep``).
    engine, progress
        As in :func:`~cq_fairing.occ.fair_shape`.

    Returns
    -------
    dict
        ``output`` (the faired file's bytes), ``faces`` (their count), ``report`` (as
        ``cq-fairing fair --report`` writes it) and ``retries`` (face runs lost with a
        worker).

    Raises
    ------
    FileFormatError
        ``data`` does not read as a model (the message names ``name``).
    """
    from .occ import fair_shape
    from .occ.convert import indexed_faces
    from .occ.faces import default_tolerance
    from .occ.io import WRITE_SUFFIXES, model_bytes

    started = time.perf_counter()
    model = _read(name, data)
    if settings.convert:
        model = model.converted()
    tol = settings.tol or default_tolerance(model.shape) * (settings.rel_tol / 1e-3)
    result = fair_shape(model.shape, tol=tol, method=settings.method,
                        objective=settings.objective or "auto",
                        borders=settings.borders or "auto", progress=progress,
                        boundary=settings.boundary, target_degree=settings.target_degree,
                        in_place=True, joins=settings.joins, angle_tol=settings.angle_tol,
                        grading=settings.grading, engine=engine)
    kind = WRITE_SUFFIXES[Path(output_name).suffix.lower()]
    output = model_bytes(model, kind)
    report = shape_report(result, tol, time.perf_counter() - started,
                          kept=model.contents() if kind == "step" else None,
                          parts=model.face_parts(), input_path=name, output_path=output_name,
                          method=settings.method, objective=settings.objective,
                          borders=settings.borders, grading=settings.grading,
                          command="cq-fairing batch")
    return dict(output=output, faces=len(indexed_faces(model.shape)), report=report,
                retries=getattr(engine, "retries", 0))


def _read(name, data):
    """The model in ``data``, read from a temporary file of ``name``'s base name."""
    from .occ.io import read_model

    with tempfile.TemporaryDirectory(prefix="cq_fairing_") as folder:
        path = Path(folder) / Path(name).name
        path.write_bytes(data)
        try:
            return read_model(path)
        except FileFormatError as exc:
            raise FileFormatError(str(exc).replace(str(path), str(name))) from None


def fair_model_task(name, data, settings, output_name):
    """:func:`fair_model` as a Dask task: its faces as tasks of their own, its progress
    as events on :data:`PROGRESS_TOPIC` (``{"model", "done", "total"}``); an input that
    does not read as a model gives ``{"unreadable": message}``."""
    client = get_client()

    def progress(done, total, _report):
        client.log_event(PROGRESS_TOPIC, {"model": name, "done": done, "total": total})

    label = hashlib.sha256(name.encode()).hexdigest()[:12]
    try:
        return fair_model(name, data, settings, output_name, DaskFaces(label), progress)
    except FileFormatError as exc:   # an expected outcome, not a task failure to log
        return dict(unreadable=str(exc))


# -- the cluster -----------------------------------------------------------------------------
def open_cluster(scheduler=None, workers=None, quiet=False):
    """A client of the scheduler at ``scheduler`` (``tcp://host:port``), or of a new
    local cluster of ``workers`` single-threaded worker processes (with
    :data:`WORKER_ENVIRON`).

    Returns
    -------
    (Client, LocalCluster or None)
        Close both when done (the cluster is ``None`` for a scheduler of your own).

    Raises
    ------
    InvalidInputError
        The scheduler cannot be reached.
    """
    if scheduler is not None:
        try:
            return Client(scheduler, timeout="20s"), None
        except (OSError, TimeoutError) as exc:
            raise InvalidInputError(f"cannot reach the Dask scheduler at {scheduler}: {exc}; "
                                    "check the address and that the scheduler runs.") from None
    with dask.config.set({"distributed.scheduler.allowed-failures": ATTEMPTS - 1,
                          **WORKER_ENVIRON}):
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=None,
                               silence_logs=logging.CRITICAL if quiet else logging.ERROR)
    return Client(cluster), cluster


# -- many models -----------------------------------------------------------------------------
def run_models(client, jobs, settings, finished, progress=None):
    """Fair every model of ``jobs`` on the cluster of ``client``.

    Parameters
    ----------
    jobs : list of (name, path, output_name)
        The input's name in reports, its file, the output's name in reports.
    settings : Settings
    finished : callable
        ``finished(job, result, retries, error)`` as each model ends, in the order
        they end: ``result`` as :func:`fair_model` returns it (``None`` when the model
        failed), ``retries`` the runs lost with workers (the model's and its faces'),
        ``error`` the exception of a failed model (``None`` otherwise).
    progress : callable, optional
        ``progress(event)`` with each progress event of the workers.

    At most twice as many models as the cluster has threads are in flight at once (the
    others' bytes are read when their turn comes).
    """
    if progress is not None:
        client.subscribe_topic(PROGRESS_TOPIC, lambda event: progress(event[1]))
    window = max(2, 2 * sum(client.nthreads().values()))
    waiting, running = list(jobs), {}
    pool = as_completed()
    while waiting or running:
        while waiting and len(running) < window:
            job = waiting.pop(0)
            future = client.submit(fair_model_task, job[0], Path(job[1]).read_bytes(),
                                   settings, job[2],
                                   key=f"cq-fairing-model-{tokenize(job, settings.as_dict())}")
            running[future] = job
            pool.add(future)
        future = next(pool)
        job = running.pop(future)
        retries = _lost_runs(client, [future.key])
        try:
            result = future.result()
        except Exception as exc:   # this model's failure; the others go on
            finished(job, None, retries, exc)
        else:
            if "unreadable" in result:
                finished(job, None, retries, FileFormatError(result["unreadable"]))
            else:
                finished(job, result, retries + result["retries"], None)
        future.release()
    if progress is not None:
        client.unsubscribe_topic(PROGRESS_TOPIC)
