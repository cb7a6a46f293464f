"""The public API's contract: numpydoc docstrings that document every parameter, and unknown keywords rejected.

The public API is what the modules below list in ``__all__``; the list is written out here, so a module that
drops out of it fails this test instead of leaving the contract quietly.
"""

import dataclasses
import importlib
import inspect

import pytest
from numpydoc.docscrape import ClassDoc, FunctionDoc

PUBLIC_MODULES = [
    "cosim.compile",
    "cosim.fmi",
    "cosim.experiment",
    "cosim.parallel",
    "cosim.freqresp",
    "cosim.master",
    "cosim.calibrate",
    "cosim.diagnose",
    "cosim.haptic",
    "cosim.config",
    "cosim.plugins",
    "controllers.base",
    "controllers.foc",
    "controllers.outer",
    "controllers.haptic",
    "controllers.playback",
]


def _public():
    """(qualified name, object) of every public function and class."""
    for module_name in PUBLIC_MODULES:
        module = importlib.import_module(module_name)
        for name in module.__all__:
            obj = getattr(module, name)
            if inspect.isfunction(obj) or inspect.isclass(obj):
                yield f"{module_name}.{name}", obj


def _constructor(obj):
    """The callable whose parameters the docstring documents: a class's own ``__init__`` (an inherited one
    is documented where it is defined), or the function itself."""
    if inspect.isclass(obj):
        return obj.__dict__.get("__init__")
    return obj


def _documented(doc, obj):
    sections = ["Parameters", "Other Parameters"]
    if dataclasses.is_dataclass(obj):
        sections.append("Attributes")  # a dataclass's constructor arguments are its fields
    names = set()
    for section in sections:
        for param in doc[section]:
            names.update(part.strip().lstrip("*") for part in param.name.split(","))
    return names


@pytest.mark.parametrize("name, obj", list(_public()), ids=[name for name, _ in _public()])
def test_public_docstring_documents_every_parameter(name, obj):
    assert inspect.getdoc(obj), f"{name} has no docstring"
    function = _constructor(obj)
    if function is None:
        return
    doc = ClassDoc(obj) if inspect.isclass(obj) else FunctionDoc(obj)
    wanted = [p.name for p in inspect.signature(function).parameters.values()
              if p.name not in ("self", "cls") and p.kind is not p.VAR_POSITIONAL]
    missing = [p for p in wanted if p not in _documented(doc, obj)]
    assert not missing, f"{name}: parameters not in its docstring's Parameters section: {missing}"


def _takes_any_keyword(obj):
    function = _constructor(obj)
    if function is None:
        return False
    return any(p.kind is p.VAR_KEYWORD for p in inspect.signature(function).parameters.values())


def _controller_with_bogus_keyword():
    from controllers.foc import FOC

    FOC(rate=1000.0, jit=False, not_a_parameter=1.0)


# Every public callable that takes **kwargs, with a call that passes an unknown keyword: it must raise
# TypeError naming the keyword before doing any work.
UNKNOWN_KEYWORD_CALLS = {
    "controllers.base.Controller": _controller_with_bogus_keyword,
}


def test_every_public_callable_taking_any_keyword_is_checked_here():
    taking = {name for name, obj in _public() if _takes_any_keyword(obj)}
    assert taking == set(UNKNOWN_KEYWORD_CALLS)


@pytest.mark.parametrize("name", sorted(UNKNOWN_KEYWORD_CALLS))
def test_an_unknown_keyword_is_a_type_error_naming_it(name):
    with pytest.raises(TypeError, match="not_a_parameter"):
        UNKNOWN_KEYWORD_CALLS[name]()
