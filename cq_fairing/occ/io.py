"""Model files in and out: STEP, IGES and BREP through OCCT's own readers and writers.

STEP files are read into an XDE document (:mod:`cq_fairing.occ.document`): a model
read with :func:`read_model`, faired in place and written with :func:`write_model`
keeps its products, instances, names, colours and layers.

Writing is atomic: OCCT writes the model into memory, Python writes those bytes to a
temporary file ``.cq_fairing_*`` in the destination folder (so a full disk or a file
size limit is an ordinary ``OSError`` whose reason is reported), that file is read
back, checked (``BRepCheck_Analyzer``, same number of faces) and only then renamed
over the destination (:func:`cq_fairing.report.publish`: the mode of a plainly written
file, not ``mkstemp``'s ``0o600``).  A failed write leaves nothing; temporaries that a
killed process left behind are removed by a later write into the same folder
(:func:`cq_fairing.report.remove_stale_temporaries`).

OCCT's transfer banners and statistics (printed by its default messenger on standard
output) and what its readers print straight to ``std::cout`` (the BREP reader's "Not a
Curve table" on a truncated file) are silenced during every read and write
(:func:`quiet_occt`).
"""

import ctypes
import io
import os
import sys
from contextlib import contextmanager
from pathlib import Path

from OCP.BRep import BRep_Builder
from OCP.BRepCheck import BRepCheck_Analyzer
from OCP.BRepTools import BRepTools
from OCP.IFSelect import IFSelect_ReturnStatus
from OCP.IGESControl import IGESControl_Reader
from OCP.Interface import Interface_Static
from OCP.Message import Message
from OCP.STEPControl import STEPControl_AsIs, STEPControl_Reader, STEPControl_Writer
from OCP.TopoDS import TopoDS_Shape

from ..errors import FileFormatError, InvalidOutputError, OutputPathError
from ..report import atomic_output, folder_error
from .convert import as_shape, indexed_faces
from .document import Model, document_step_bytes, read_step_model, written_step

__all__ = ["read_shape", "read_model", "write_shape", "write_model", "model_bytes",
           "write_model_bytes", "step_length_unit",
           "quiet_occt", "READ_SUFFIXES", "WRITE_SUFFIXES"]

READ_SUFFIXES = {".step": "step", ".stp": "step", ".igs": "iges", ".iges": "iges",
                 ".brep": "brep", ".brp": "brep"}
WRITE_SUFFIXES = {".step": "step", ".stp": "step", ".brep": "brep", ".brp": "brep"}


def _kind(path, table, verb):
    kind = table.get(Path(path).suffix.lower())
    if kind is None:
        raise FileFormatError(
            f"cannot {verb} '{path}': expected a suffix in {sorted(table)}, got "
            f"'{Path(path).suffix or '(none)'}'."
        )
    return kind


def read_shape(path):
    """Read a STEP (.step/.stp), IGES (.igs/.iges) or BREP (.brep) file.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    TopoDS_Shape
        All roots of the file (a compound when there are several).

    Raises
    ------
    FileFormatError
        The file is missing, empty, not readable, corrupt or truncated, or holds no shape
        with at least one face.
    """
    return read_model(path).shape


def read_model(path):
    """Read a model file as :func:`read_shape` does, keeping a STEP file's XDE document.

    Returns
    -------
    Model
        The flat shape (the faces :func:`read_shape` gives, in its order) and, for STEP,
        the document with the file's products, instances, names, colours and layers
        (:mod:`cq_fairing.occ.document`); :func:`write_model` writes both back.

    Raises
    ------
    FileFormatError
        As :func:`read_shape`.
    """
    path = Path(path)
    kind = _kind(path, READ_SUFFIXES, "read")
    if not path.is_file():
        raise FileFormatError(f"cannot read '{path}': no such file; check the path.")
    if path.stat().st_size == 0:
        raise FileFormatError(f"cannot read '{path}': the file is empty.")
    model = {"step": _read_step, "iges": _read_iges, "brep": _read_brep}[kind](path)
    if model.shape is None or model.shape.IsNull() or not indexed_faces(model.shape):
        raise FileFormatError(
            f"'{path}' was read as {kind.upper()} but holds no shape with faces; "
            "the file may be truncated or contain only points/curves."
        )
    return model


@contextmanager
def quiet_occt():
    """Silence OCCT's printing on standard output for the block, then restore it.

    OCCT's data exchange prints banners and transfer statistics through
    ``Message::DefaultMessenger()``, whose printers are detached; some readers (BREP's
    curve, surface and shape tables) write to ``std::cout`` directly, so file
    descriptor 1 points at the null device too (:func:`_stdout_to_devnull`).  Both are
    left as they were found, also when the block raises.
    """
    messenger = Message.DefaultMessenger_s()
    printers = messenger.Printers()
    saved = [printers.Value(i) for i in range(1, printers.Size() + 1)]
    for printer in saved:
        messenger.RemovePrinter(printer)
    try:
        with _stdout_to_devnull():
            yield
    finally:
        for printer in saved:
            messenger.AddPrinter(printer)


@contextmanager
def _stdout_to_devnull():
    """Point file descriptor 1 at the null device for the block (C and C++ writes too).

    Python's buffer is flushed before the block, so nothing printed earlier is lost,
    and C's after it, so nothing printed inside leaks out later.  Where standard output
    has no descriptor (closed, or replaced by an object without one) the block runs
    unchanged.
    """
    try:
        sys.stdout.flush()
        saved = os.dup(1)
    except (AttributeError, OSError, ValueError):
        yield
        return
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 1)
        yield
    finally:
        _flush_c_streams()
        os.dup2(saved, 1)
        os.close(saved)


def _flush_c_streams():
    """``fflush(NULL)``: write out what C and C++ hold buffered (no-op without a libc)."""
    try:
        ctypes.CDLL(None).fflush(None)
    except (OSError, TypeError, AttributeError):
        pass


def _read_with(reader, kind, path):
    """All roots transferred by an OCCT XSControl reader (a ``None`` shape when there are none)."""
    with quiet_occt():
        status = reader.ReadFile(str(path))
        if status != IFSelect_ReturnStatus.IFSelect_RetDone:
            raise FileFormatError(
                f"'{path}' is not a readable {kind} file (reader status {status.name}); "
                "it may be corrupt or truncated."
            )
        reader.TransferRoots()
    return Model(reader.OneShape() if reader.NbShapes() else None)


def _read_step(path):
    with quiet_occt():
        return read_step_model(path)


_UNIT_NAMES = {"millimetre": "MM", "millimeter": "MM", "metre": "M", "meter": "M",
               "centimetre": "CM", "centimeter": "CM", "inch": "INCH", "foot": "FT",
               "micrometre": "UM", "micrometer": "UM", "kilometre": "KM", "kilometer": "KM"}


def step_length_unit(path):
    """The length unit a STEP file declares, as ``write_shape(unit=...)`` expects it.

    OCCT converts STEP coordinates to millimetres on reading; writing with the unit of
    the input (``write_shape(shape, out, unit=step_length_unit(src))``) gives a file in
    the same unit as the source.

    Returns
    -------
    str or None
        ``"MM"``, ``"M"``, ``"INCH"``, ... or ``None`` when the file names no known unit.

    Raises
    ------
    FileFormatError
        The file cannot be read as STEP.
    """
    from OCP.TColStd import TColStd_SequenceOfAsciiString

    reader = STEPControl_Reader()
    with quiet_occt():
        status = reader.ReadFile(str(path))
    if status != IFSelect_ReturnStatus.IFSelect_RetDone:
        raise FileFormatError(f"'{path}' is not a readable STEP file.")
    lengths = TColStd_SequenceOfAsciiString()
    reader.FileUnits(lengths, TColStd_SequenceOfAsciiString(), TColStd_SequenceOfAsciiString())
    names = [lengths.Value(i).ToCString().lower() for i in range(1, lengths.Length() + 1)]
    return next((_UNIT_NAMES[n] for n in names if n in _UNIT_NAMES), None)


def _read_iges(path):
    return _read_with(IGESControl_Reader(), "IGES", path)


def _read_brep(path):
    shape = TopoDS_Shape()
    with quiet_occt():
        read = BRepTools.Read_s(shape, str(path), BRep_Builder())
    if not read:
        raise FileFormatError(
            f"'{path}' is not a readable BREP file; it may be corrupt or truncated."
        )
    return Model(shape)


def _check_output(path, force):
    if path.is_dir():
        raise OutputPathError(f"cannot write '{path}': it is a folder; give a file name.")
    kind = _kind(path, WRITE_SUFFIXES, "write")
    folder = path.parent if str(path.parent) else Path(".")
    problem = folder_error(folder)
    if problem:
        raise OutputPathError(f"cannot write '{path}': {problem}.")
    if path.exists() and not force:
        raise OutputPathError(
            f"'{path}' already exists; choose another name or pass force=True to overwrite."
        )
    if not os.access(folder, os.W_OK):
        raise OutputPathError(f"cannot write '{path}': folder '{folder}' is not writable.")
    return kind


def write_shape(shape, path, *, force=False, input_path=None, unit=None):
    """Write ``shape`` to a STEP or BREP file atomically, after validating it.

    Parameters
    ----------
    shape : TopoDS_Shape or cadquery.Shape
    path : str or os.PathLike
        ``.step``/``.stp`` or ``.brep``.
    force : bool, optional
        Overwrite an existing file.
    input_path : str or os.PathLike, optional
        The file the shape was read from; writing over it is refused (inputs are never
        changed).
    unit : str, optional
        STEP length unit written (``"MM"``, ``"M"``, ``"INCH"``...); default is OCCT's
        ``write.step.unit`` (millimetres).  Coordinates are never scaled by this module.

    Raises
    ------
    OutputPathError
        The path exists (without ``force``), is the input, is a folder, its folder is
        missing or not writable.
        Also when the bytes do not fit (a full disk, a file size limit): the message
        names the reason (``strerror``), the bytes written and the free space.
    FileFormatError
        Unknown suffix.
    InvalidOutputError
        OCCT could not transfer the shape, or the written file does not read back as a
        valid shape with the same number of faces (nothing is written).
    """
    write_model(Model(as_shape(shape)), path, force=force, input_path=input_path, unit=unit)


def write_model(model, path, *, force=False, input_path=None, unit=None):
    """Write a :class:`~cq_fairing.occ.document.Model` as :func:`write_shape` writes a shape.

    A model with a document written as STEP keeps the products, instances, names,
    colours and layers it was read with (:func:`~cq_fairing.occ.document.document_step_bytes`);
    as BREP, or without a document, only its shape is written.  Parameters and errors
    as in :func:`write_shape`.
    """
    path = Path(path)
    if input_path is not None and Path(input_path).resolve() == path.resolve():
        raise OutputPathError(
            f"refusing to write over the input file '{path}'; choose another output name."
        )
    kind = _check_output(path, force)
    write_model_bytes(model_bytes(model, kind, unit), path, len(indexed_faces(model.shape)),
                      force=force)


def model_bytes(model, kind, unit=None):
    """The file of a :class:`~cq_fairing.occ.document.Model` as bytes, in memory.

    Parameters
    ----------
    model : Model
    kind : {"step", "brep"}
        A STEP file keeps the model's document (products, names, colours, layers).
    unit : str, optional
        STEP length unit, as in :func:`write_shape`.
    """
    with quiet_occt(), _step_unit(unit):
        if kind == "brep":
            return _brep_bytes(model.shape)
        if model.document is not None:
            return document_step_bytes(model.document)
        return _step_bytes(model.shape)


def write_model_bytes(data, path, n_faces, *, force=False):
    """Write a model file's ``data`` (:func:`model_bytes`) to ``path`` atomically: to a
    temporary beside it, read back and checked (``BRepCheck_Analyzer``, ``n_faces``
    faces), then renamed into place.

    Raises
    ------
    OutputPathError, FileFormatError
        As :func:`write_shape`.
    """
    path = Path(path)
    _check_output(path, force)
    with atomic_output(path, force=force) as tmp:
        _write_bytes(tmp, data, path)
        _verify_written(tmp, n_faces)


def _write_bytes(tmp, data, path):
    """Write ``data`` to ``tmp`` and flush it to disk; a failure names the reason."""
    try:
        with open(tmp, "wb") as handle:
            handle.write(data)
            handle.flush()
            os.fsync(handle.fileno())
    except OSError as exc:
        raise OutputPathError(
            f"cannot write '{path}': {exc.strerror or os.strerror(exc.errno)} after "
            f"{_size(tmp)} of {len(data)} bytes ({_free_space(tmp)}); nothing was written."
        ) from exc


def _size(path):
    try:
        return os.path.getsize(path)
    except OSError:
        return 0


def _free_space(path):
    """``"N MB free on the device"`` of the folder of ``path``."""
    try:
        info = os.statvfs(os.path.dirname(os.path.abspath(path)))
    except OSError:
        return "free space unknown"
    return f"{info.f_bavail * info.f_frsize / 1e6:.1f} MB free on the device"


@contextmanager
def _step_unit(unit):
    """OCCT's ``write.step.unit`` set to ``unit`` for the block (unchanged for ``None``)."""
    previous = Interface_Static.CVal_s("write.step.unit")
    try:
        if unit is not None:
            Interface_Static.SetCVal_s("write.step.unit", str(unit).upper())
        yield
    finally:
        Interface_Static.SetCVal_s("write.step.unit", previous)


def _step_bytes(shape):
    """The STEP file of ``shape`` as bytes (OCCT's writer, into memory)."""
    writer = STEPControl_Writer()
    status = writer.Transfer(shape, STEPControl_AsIs)
    if status != IFSelect_ReturnStatus.IFSelect_RetDone:
        raise InvalidOutputError(
            f"STEP transfer of the shape failed (status {status.name}); nothing was written.")
    return written_step(writer)


def _brep_bytes(shape):
    """The BREP (text) file of ``shape`` as bytes."""
    stream = io.BytesIO()
    BRepTools.Write_s(shape, stream)
    data = stream.getvalue()
    if not data:
        raise InvalidOutputError("writing the BREP data failed; nothing was written.")
    return data


def _verify_written(tmp, n_faces):
    """Refuse a written temporary that does not read back as a valid shape with
    ``n_faces`` faces (:class:`~cq_fairing.errors.InvalidOutputError`)."""
    try:
        back = read_shape(tmp)
    except FileFormatError as exc:
        raise InvalidOutputError(
            f"the written file cannot be read back ({exc}); nothing was written.") from exc
    got = len(indexed_faces(back))
    if got != n_faces:
        raise InvalidOutputError(
            f"the written file reads back with {got} faces instead of {n_faces}; "
            "nothing was written."
        )
    if not BRepCheck_Analyzer(back).IsValid():
        raise InvalidOutputError(
            "the written file does not read back as a valid shape (BRepCheck_Analyzer); "
            "nothing was written."
        )
