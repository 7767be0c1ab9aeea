"""``cq-fairing batch``: fair many models on a Dask cluster.

``batch INPUTS... -o OUT_DIR [--tol T | --rel-tol R] [fair's options]
[--scheduler tcp://HOST:PORT | --workers N] [--resume] [--force] [--quiet]``

INPUTS are model files (STEP, IGES, BREP), folders (their model files) or glob
patterns.  Each model ``NAME.EXT`` gives ``OUT_DIR/NAME.EXT`` (an IGES model is written
as ``NAME.step``), its report ``OUT_DIR/NAME.report.json`` and ``.html`` (as ``fair
--report`` writes them, plus a ``batch`` entry: the input's SHA-256, the options, the
output's SHA-256, the retries), and the batch ``OUT_DIR/summary.json`` and
``summary.html``.  ``--resume`` skips a model whose output and report exist and whose
report records the input's SHA-256, these options and the output's SHA-256.

Exit code: 0 when every model was faired and every face met the tolerance, 1 when some
face did not (or failed), 3 when some input could not be read, 5 when some model failed
otherwise (its worker died twice, an internal error); the other models are done in
every case.  The engine is in :mod:`cq_fairing.batch` (``pip install
"cq-fairing[dask]"``).
"""

import glob
import os
import sys
import time
from pathlib import Path

from .errors import FileFormatError, InvalidInputError, OutputPathError

__all__ = ["add_batch_command", "command_batch"]

_WRITTEN_AS = {".igs": ".step", ".iges": ".step"}


def add_batch_command(sub):
    """Register ``batch`` on the ``cq-fairing`` subparsers ``sub``."""
    from .cli_options import add_fairing_options, integer_at_least, positive_float

    batch = sub.add_parser(
        "batch", help="fair many models on a Dask cluster",
        description="Fair every model of INPUTS into OUT_DIR: NAME.EXT faired (IGES as "
                    "NAME.step), its report NAME.report.json and .html, and summary.json "
                    "and .html over all models.",
        epilog="exit code: 0 all faired within tolerance, 1 some face failed or missed "
               "it, 3 some input unreadable, 5 some model failed otherwise; the other "
               "models are done in every case.")
    batch.add_argument("inputs", nargs="+", metavar="INPUT",
                       help="model files, folders of model files, or glob patterns")
    batch.add_argument("-o", "--output-dir", type=Path, required=True, metavar="OUT_DIR")
    tol = batch.add_mutually_exclusive_group()
    tol.add_argument("--tol", type=positive_float,
                     help="largest allowed deviation in model units, for every model")
    tol.add_argument("--rel-tol", type=positive_float, default=1e-3, metavar="R",
                     help="largest allowed deviation as a fraction of each model's "
                          "bounding-box diagonal (default 1e-3)")
    add_fairing_options(batch)
    batch.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                       help="run on this Dask scheduler's workers (default: a local cluster)")
    batch.add_argument("--workers", type=integer_at_least(1, "a number of workers"),
                       metavar="N", help="worker processes of the local cluster "
                                         f"(default: the cores, {os.cpu_count()})")
    batch.add_argument("--resume", action="store_true",
                       help="skip models whose output and report are already there and "
                            "up to date (same input and options)")
    batch.add_argument("--force", action="store_true", help="overwrite existing outputs")
    batch.add_argument("--quiet", action="store_true", help="no progress bars")
    batch.set_defaults(handler=command_batch, target=None)   # no --target: one per model


def command_batch(args):
    """Run ``cq-fairing batch``; returns the exit code."""
    from .cli_options import check_method, target_degree_option
    from .core.options import DEFAULTS
    from .report import batch_summary, batch_table, write_batch_summary

    check_method(args)
    if args.scheduler and args.workers:
        raise InvalidInputError("give --scheduler or --workers, not both: the workers of "
                                "a scheduler of your own are started with it.")
    try:
        from . import batch
    except ImportError as exc:
        raise InvalidInputError(f"batch needs Dask ({exc}); pip install 'cq-fairing[dask]'.") \
            from None
    settings = batch.Settings(
        tol=args.tol, rel_tol=None if args.tol else args.rel_tol, method=args.method,
        objective=args.objective, borders=args.borders, joins=args.joins,
        angle_tol=args.angle_tol, target_degree=target_degree_option(args.target_degree),
        boundary=args.boundary or DEFAULTS["boundary"],
        grading=args.grading or DEFAULTS["grading"], convert=args.convert)
    models = _models(args.inputs)
    folder = _output_dir(args.output_dir)
    summary_paths = folder / "summary.json", folder / "summary.html"
    run = _Run(args, settings, folder, batch)
    pending = run.plan(models, summary_paths)
    started = time.perf_counter()
    if pending:
        run.fair(pending)
    summary = batch_summary(
        [run.rows[str(m)] for m in models], command="cq-fairing " + " ".join(sys.argv[1:]),
        output_dir=folder, settings=settings.as_dict(), engine=run.engine,
        seconds=time.perf_counter() - started)
    write_batch_summary(summary, *summary_paths, force=True)
    print(batch_table(summary))
    return _exit_code(run)


def _exit_code(run):
    """5 when a model failed but for an unreadable input, else 3 when an input was
    unreadable, else 1 when a face failed or missed its tolerance, else 0."""
    from .cli_options import EXIT_INPUT, EXIT_INTERNAL, EXIT_OK, EXIT_TOLERANCE

    rows = run.rows.values()
    failed = sum(r["status"] == "failed" for r in rows)
    short = any((r["faces_failed"] or 0) + (r["faces_tolerance_not_met"] or 0) for r in rows)
    for code, found in ((EXIT_INTERNAL, failed > len(run.unreadable)),
                        (EXIT_INPUT, run.unreadable), (EXIT_TOLERANCE, short)):
        if found:
            return code
    return EXIT_OK


def _models(inputs):
    """The model files named by ``inputs``, each once, in order: a file as given, the
    model files (by suffix) in a folder or matching a glob pattern.

    Raises
    ------
    FileFormatError
        An input names no model file.
    """
    from .occ.io import READ_SUFFIXES

    found = []
    for text in inputs:
        path = Path(text)
        if path.is_dir():
            matches = sorted(p for p in path.iterdir()
                             if p.is_file() and p.suffix.lower() in READ_SUFFIXES)
        elif path.exists():
            matches = [path]
        else:
            matches = sorted(Path(p) for p in glob.glob(text, recursive=True)
                             if Path(p).is_file() and Path(p).suffix.lower() in READ_SUFFIXES)
        if not matches:
            raise FileFormatError(f"'{text}' names no model file (expected a file, a folder "
                                  f"of {'/'.join(sorted(READ_SUFFIXES))} files or a glob "
                                  "pattern); check the path.")
        found += [p for p in matches if p.resolve() not in {q.resolve() for q in found}]
    return found


def _output_dir(folder):
    if folder.exists() and not folder.is_dir():
        raise OutputPathError(f"-o '{folder}' is a file; give a folder for the outputs.")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputPathError(f"cannot make the output folder '{folder}': "
                              f"{exc.strerror or exc}.") from None
    return folder


def output_paths(folder, model):
    """``(output, JSON report, HTML report)`` of ``model`` in ``folder``."""
    suffix = _WRITTEN_AS.get(model.suffix.lower(), model.suffix)
    return (folder / (model.stem + suffix), folder / (model.stem + ".report.json"),
            folder / (model.stem + ".report.html"))


class _Run:
    """The models of one batch: what to skip, what to fair, and each model's row."""

    def __init__(self, args, settings, folder, batch):
        self.args, self.settings, self.folder, self.batch = args, settings, folder, batch
        self.rows, self.paths, self.hashes = {}, {}, {}
        self.unreadable = set()     # models whose input did not read as a model
        self.engine = None

    def plan(self, models, summary_paths):
        """The models to fair; the others (``--resume``: up to date) get their rows.

        Raises
        ------
        InvalidInputError
            Two models would write the same output.
        OutputPathError
            An output exists and neither ``--force`` nor ``--resume`` was given.
        """
        from .report import model_row

        owners = {}
        for model in models:
            paths = output_paths(self.folder, model)
            if paths[0] in owners:
                raise InvalidInputError(
                    f"'{owners[paths[0]]}' and '{model}' would both be written to "
                    f"'{paths[0]}'; give models of different names, or run them apart.")
            owners[paths[0]] = model
            self.paths[str(model)] = paths
        existing = [p for paths in self.paths.values() for p in paths if p.exists()]
        existing += [p for p in summary_paths if p.exists() and not self.args.resume]
        if existing and not (self.args.force or self.args.resume):
            raise OutputPathError(
                f"'{existing[0]}' already exists ({len(existing)} outputs do); pass --resume "
                "to keep those that are up to date, or --force to make them again.")
        pending = []
        for model in models:
            try:
                self.hashes[str(model)] = self.batch.sha256(model)
            except OSError as exc:
                self._failed(str(model), 0, FileFormatError(
                    f"cannot read '{model}': {exc.strerror or exc}."))
                continue
            report = self._up_to_date(model)
            if report is None:
                pending.append(model)
            else:
                output, json_path, _ = self.paths[str(model)]
                self.rows[str(model)] = model_row(
                    report, input_path=model, status="resumed", output_path=output,
                    report_path=json_path, seconds=0.0, retries=report["batch"]["retries"])
        return pending

    def _up_to_date(self, model):
        """The model's report when ``--resume`` may keep its output, else ``None``."""
        import json

        output, json_path, html_path = self.paths[str(model)]
        if not (self.args.resume and output.is_file() and json_path.is_file()
                and html_path.is_file()):
            return None
        try:
            report = json.loads(json_path.read_text())
            record = report["batch"]
        except (ValueError, KeyError, TypeError):
            return None
        same = (record.get("input_sha256") == self.hashes[str(model)]
                and record.get("options") == self.settings.as_dict()
                and record.get("output_sha256") == self.batch.sha256(output))
        return report if same else None

    def fair(self, models):
        """Fair ``models`` on the cluster; each one's files are written as it ends."""
        client, cluster = self.batch.open_cluster(self.args.scheduler, self.args.workers,
                                                  self.args.quiet)
        workers = len(client.nthreads())
        self.engine = (f"Dask scheduler {self.args.scheduler}" if self.args.scheduler
                       else "Dask local cluster") + f", {workers} workers"
        bars = None if self.args.quiet else _Bars(len(models))
        try:
            jobs = [(str(m), m, str(self.paths[str(m)][0])) for m in models]
            self.batch.run_models(client, jobs, self.settings, self._finished(bars),
                                  bars and bars.event)
        finally:
            if bars is not None:
                bars.stop()
            client.close()
            if cluster is not None:
                cluster.close()

    def _finished(self, bars):
        def finished(job, result, retries, error):
            try:
                self._write(job, result, retries, error)
            except Exception as exc:   # e.g. the output does not read back: this model fails
                self._failed(job[0], retries, exc)
            if bars is not None:
                bars.model_done(job[0])
        return finished

    def _write(self, job, result, retries, error):
        from .occ.io import write_model_bytes
        from .report import model_row, write_report

        name = job[0]
        if error is not None:
            self._failed(name, retries, error)
            return
        output, json_path, html_path = self.paths[name]
        write_model_bytes(result["output"], output, result["faces"], force=True)
        report = dict(result["report"], command="cq-fairing " + " ".join(sys.argv[1:]))
        report["batch"] = {"input_sha256": self.hashes[name],
                           "options": self.settings.as_dict(),
                           "output_sha256": self.batch.sha256(output), "retries": retries}
        write_report(report, html_path, force=True)
        write_report(report, json_path, force=True)     # last: it marks the model done
        self.rows[name] = model_row(
            report, input_path=name, status="done", output_path=output,
            report_path=json_path, seconds=report["summary"]["seconds"], retries=retries)

    def _failed(self, name, retries, error):
        from .report import model_row

        if isinstance(error, (FileFormatError, OutputPathError)):
            message = str(error)
        elif isinstance(error, self.batch.KilledWorker):
            message = (f"the worker fairing this model died {error.allowed_failures + 1} "
                       "times")
        else:
            message = f"{type(error).__name__}: {error}"
        self.rows[name] = model_row(input_path=name, status="failed", message=message,
                                    retries=retries)
        if isinstance(error, FileFormatError):
            self.unreadable.add(name)


class _Bars:
    """Progress bars on stderr: one over the models and one per model in flight (faces)."""

    def __init__(self, total):
        from rich.console import Console
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
        )

        self.progress = Progress(TextColumn("{task.description}"), BarColumn(),
                                 MofNCompleteColumn(), TimeElapsedColumn(),
                                 console=Console(stderr=True))
        self.overall = self.progress.add_task("models", total=total)
        self.models = {}
        self.progress.start()

    def event(self, message):
        """A worker's progress: ``{"model", "done", "total"}`` faces."""
        name = message["model"]
        if name not in self.models:
            self.models[name] = self.progress.add_task(f"  {Path(name).name}",
                                                       total=message["total"])
        self.progress.update(self.models[name], completed=message["done"],
                             total=message["total"])

    def model_done(self, name):
        if name in self.models:
            self.progress.remove_task(self.models.pop(name))
        self.progress.advance(self.overall)

    def stop(self):
        self.progress.stop()
