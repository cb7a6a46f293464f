"""Modelica front end: rumoca parses and flattens a model into its DAE IR; this module maps its failures to
cosim errors with file and line, and gives source locations for IR spans."""

import re
import tempfile
from dataclasses import dataclass
from pathlib import Path

import rumoca

from cosim.compile.der_expressions import rewrite_der_expressions
from cosim.compile.library import describe_path, find_class_file, library_fingerprint, library_session
from cosim.compile.library_subset import library_subset
from cosim.compile.refusal import refusal
from cosim.compile.source_text import locate_rumoca_error
from cosim.compile.workarounds import transformed_roots
from cosim.errors import ModelicaError, StructureError
from cosim.modelica_text import check_redeclares, find_class, line_of, model_names
from cosim.tomldoc import did_you_mean, read_text

__all__ = ["FlatModel", "load_flat_model"]

# A rumoca diagnostic locates itself as "╭─[file:line:col]" and states the problem after "×".
_LOCATION = re.compile(r"╭─\[(?P<file>[^\]]+?):(?P<line>\d+):(?P<col>\d+)\]")
_PROBLEM = re.compile(r"×\s*(?P<msg>.+?)(?:\n\s*│\s*(?P<more>.+?))?\n")


@dataclass(frozen=True)
class FlatModel:
    """A flattened model: rumoca's DAE IR plus the source texts its spans point into.

    Attributes
    ----------
    name : str
        Full Modelica name, e.g. ``Gripper.GripperPlant``.
    path : Path
        The file the model was loaded from.
    ir : dict
        ``Model.to_dict('dae')`` as rumoca returns it.
    """

    name: str
    path: Path
    ir: dict

    def locate(self, span):
        """Return ``"file:line"`` for a rumoca span dict (``{"source", "start", "end"}``), or the file alone."""
        if not span:
            return str(self.path)
        for file_id, file_name, text in self.ir.get("source_map", {}).get("files", []):
            if file_id == span.get("source"):
                line = text.count("\n", 0, span.get("start", 0)) + 1
                return f"{file_name}:{line}"
        return str(self.path)


def _first_diagnostic(diagnostics, default_file):
    """Turn rumoca's first error diagnostic into (message, file, line)."""
    for diag in diagnostics:
        if getattr(diag, "level", "error") != "error":
            continue
        text = str(getattr(diag, "message", diag))
        loc = _LOCATION.search(text)
        prob = _PROBLEM.search(text + "\n")
        message = prob.group("msg").strip() if prob else text.strip().splitlines()[0]
        if prob and prob.group("more"):
            message = f"{message} {prob.group('more').strip()}"
        if loc:
            return message, loc.group("file"), int(loc.group("line"))
        return message, getattr(diag, "file", default_file), getattr(diag, "line", None)
    return None


def load_flat_model(path, model, modelica_path=()):
    """Parse and flatten ``model`` with rumoca, from the Modelica file ``path`` or from a library.

    Parameters
    ----------
    path : str or Path or None
        A ``.mo`` file; rumoca also reads every other ``.mo`` file in its directory. None: the model is a class
        of a library on ``modelica_path`` (``Modelica.Mechanics.Rotational.Examples.First``).
    model : str
        Full name of the model, e.g. ``Pkg.Model``.
    modelica_path : sequence of Path, default ()
        Folders holding the libraries the model uses (:func:`~cosim.compile.library.library_path`), e.g. the
        folder that holds ``Modelica/``.

    Returns
    -------
    FlatModel

    Raises
    ------
    ModelicaError
        Missing file, syntax error (with file:line), unknown model name, a class found in no library (named, with
        the folders looked in).
    StructureError
        rumoca found the model unbalanced (more or fewer equations than unknowns).
    UnsupportedConstructError
        A ``redeclare`` form that rumoca would ignore without a word (:func:`~cosim.modelica_text.check_redeclares`).
    """
    given = tuple(Path(r) for r in modelica_path)
    # a library with a construct this rumoca version miscounts is read from a transformed copy
    roots = transformed_roots(given, rumoca.version(), library_fingerprint(given)) if given else ()
    if path is None:
        path = find_class_file(model, roots)
        if path is None:
            top = model.split(".", 1)[0]
            held = sorted({p.stem if p.suffix == ".mo" else p.name for r in roots for p in r.iterdir()
                           if p.suffix == ".mo" or (p / "package.mo").is_file()})
            raise ModelicaError(f"no library holds {top} (for the model {model}){did_you_mean(top, held)}: looked "
                                f"in {describe_path(given)}")
        files = [path]
    else:
        path = Path(path)
        if not path.is_file():
            raise ModelicaError(f"no such Modelica file: {path}")
        for mo in sorted(path.parent.glob("*.mo")):
            read_text(mo, "Modelica source", error=ModelicaError)  # rumoca fails on non-UTF-8 with no location
            found = _first_diagnostic(rumoca.validate(str(mo)), str(mo))
            if found:
                message, file, line = found
                raise ModelicaError(message, file=file, line=line)
        check_redeclares(path.read_text(encoding="utf-8"), str(path))
        files = [path] + [mo for mo in sorted(path.parent.glob("*.mo")) if mo != path]
    copies = {str(copy): str(root) for copy, root in zip(roots, given) if copy != root}
    with tempfile.TemporaryDirectory(prefix="cosim-der-") as scratch:
        try:
            ir = _load(path, model, files, Path(scratch), roots)
        except rumoca.RumocaError as err:
            error = _front_end_error(err, path, model, files, roots)
            if isinstance(error, StructureError) and not roots:
                error.padded = _padded(path, model, files, str(err))
            if copies:
                error.file, error.args = _users(error.file, copies), (_users(str(error), copies),)
            raise error from err
    if copies:
        _rename_sources(ir, lambda name: _users(name, copies))
    return FlatModel(name=model, path=path, ir=ir)


def _users(text, copies):
    """``text`` naming the user's library files where it names their transformed copies (same lines)."""
    for copy, root in copies.items():
        text = text and text.replace(copy + "/", root + "/")
    return text


def _rename_sources(ir, rename):
    """Pass the file names of ``ir``'s source map through ``rename`` (a copy's name to the user's file)."""
    ir["source_map"]["files"] = [[file_id, rename(name), text] for file_id, name, text in ir["source_map"]["files"]]


_BALANCE = re.compile(r"balance = (-?\d+)")
PAD = "_cosim_pad_"  # the names of the unknowns :func:`_padded` adds


def _padded(path, model, files, text):
    """The IR of an unbalanced ``model`` made square for rumoca, so that its equations and unknowns can be told
    apart (:mod:`cosim.compile.balance`): ``n`` equations ``0.0 = 0.0`` added when it lacks ``n``, ``n`` unknowns
    ``PAD1..`` (in no equation) when it has ``n`` too many. None when the model's text cannot be padded."""
    found = _BALANCE.search(text)
    source = path.read_text(encoding="utf-8")
    body = find_class(source, model) if found else None
    if body is None:
        return None
    n = int(found.group(1))
    end = source.index(body) + len(body) - len(body.rsplit("\n", 1)[-1])  # the start of the "end Model;" line
    pad = ("equation\n" + "  0.0 = 0.0;\n" * -n if n < 0 else
           "public\n" + "".join(f"  Real {PAD}{k};\n" for k in range(n)))
    with tempfile.TemporaryDirectory(prefix="cosim-balance-") as scratch:
        for mo in files:
            text_of = source[:end] + pad + source[end:] if mo == path else mo.read_text(encoding="utf-8")
            (Path(scratch) / mo.name).write_text(text_of, encoding="utf-8")
        try:
            ir = rumoca.Session().load(str(Path(scratch) / path.name), model=model).to_dict("dae")
        except rumoca.RumocaError:
            return None
        originals = {str(Path(scratch) / mo.name): str(mo) for mo in files}
        _rename_sources(ir, lambda name: originals.get(name, name))
    return FlatModel(name=model, path=path, ir=ir)


def _load(path, model, files, scratch, roots):
    """rumoca's DAE IR of ``model``; when a file has ``der()`` of an expression, from rewritten copies of the
    directory's files (:func:`~cosim.compile.der_expressions.rewrite_der_expressions`), with the source map
    naming the original files (the rewriting keeps every line). A library's own files are loaded as they are."""
    in_library = any(path.is_relative_to(root.resolve()) for root in roots)
    rewritten = {} if in_library else {
        mo: rewrite_der_expressions(mo.read_text(encoding="utf-8"), str(k)) for k, mo in enumerate(files)}
    if any(count for _, count in rewritten.values()):
        for mo, (text, _) in rewritten.items():
            (scratch / mo.name).write_text(text, encoding="utf-8")
        source = scratch / path.name
    else:
        source = path
    # No local names rumoca's Session or Model: they are unsendable PyO3 objects, and a frame a Dask worker's
    # profiler still holds when this returns would drop them on the profiler's thread (a RuntimeError printed
    # by tornado, the objects leaked). A library session is kept by this thread (library.library_session).
    originals = {str(scratch / mo.name): str(mo) for mo in files} if source != path else {}
    if roots:
        ir = _library_load(source, model, [] if in_library else files, roots, originals)
    else:
        ir = rumoca.Session().load(str(source), model=model).to_dict("dae")
    _rename_sources(ir, lambda name: originals.get(name, name))
    return ir


def _library_load(source, model, files, roots, originals):
    """rumoca's DAE IR of ``model`` with the library path ``roots``: first from a copy of only the library files
    the model and the user's ``files`` use (:func:`~cosim.compile.library_subset.library_subset`; rumoca reads
    every file under its roots), then, if that fails (a class the text scan missed, or an error of the model's
    own), from the whole library path, whose session this thread keeps (its errors name the library's files).
    ``originals`` gains the copies' original names."""
    with tempfile.TemporaryDirectory(prefix="cosim-libraries-") as subset:
        copies = library_subset(model, [mo.read_text(encoding="utf-8") for mo in files], roots, Path(subset))
        lifted = {original: copy for copy, original in copies.items()}
        try:
            ir = rumoca.Session(roots=[subset]).load(lifted.get(str(source), str(source)),
                                                     model=model).to_dict("dae")
        except rumoca.RumocaError:
            return library_session(roots).load(str(source), model=model).to_dict("dae")
    originals.update(copies)
    return ir


_UNRESOLVED_TYPE = re.compile(r"unresolved type reference: '(?P<name>[\w.]+)'")


def _missing_class_error(text, files, roots):
    """A class rumoca could not find (a library not on the path): named, with its first use and where cosim
    looked; None when rumoca's error is not about one."""
    found = _UNRESOLVED_TYPE.search(text)
    if not found:
        return None
    name = found.group("name")
    file, line = str(files[0]), None
    for mo in files:
        text = mo.read_text(encoding="utf-8")
        if name in text:
            file, line = str(mo), line_of(text, text.index(name))
            break
    folders = [str(files[0].parent.resolve())] + [str(r) for r in roots]
    hint = "" if roots else f"; {describe_path(roots)}"
    return ModelicaError(f"class {name} not found: looked in {', '.join(folders)}{hint}", file=file, line=line)


def _front_end_error(err, path, model, files, roots=()):
    text = str(err)
    missing = _missing_class_error(text, files, roots)
    if missing is not None:
        return missing
    if "resolve/parse failed" in text or "not found" in text.lower():
        names = [n for mo in files for n in model_names(mo.read_text(encoding="utf-8"))]
        return ModelicaError(f"no model named {model!r} in {path.parent}{did_you_mean(model, names)}", file=str(path))
    if "unbalanced" in text:
        message, file, line = refusal(model, "unbalanced model: " + text.split("unbalanced model:")[-1].strip(),
                                      path, roots)
        return StructureError(message, file=file, line=line)
    said = text.splitlines()[0].removeprefix(f"{model} could not be compiled: ")
    return locate_rumoca_error(text, files) or ModelicaError(*refusal(model, said, path, roots))
