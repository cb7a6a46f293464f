"""Mutated job and config files, and haptic table requests and arguments, for the fuzz test (tests/test_fuzz.py) and
its long run (benchmarks/fuzz.py).

A case is a shipped example's TOML text with a few mutations a user could make: a value replaced by a value of
any type (numbers out of range, strings, lists, tables), a line deleted or duplicated, a key renamed, and
``--set`` overrides on existing, extended or made-up key paths with any value or any text. :func:`check` loads the
case with the real loader and returns the class of the project's error it raised (or "ok"); any other exception
escapes, which is the failure the fuzz looks for. :func:`haptic_cases` and :func:`check_haptic` do the same for the
haptic command: its table loaders called with any value, its arguments parsed from any text.
"""

import datetime
import math
import re
import shutil
import tomllib
import warnings
from pathlib import Path

from hypothesis import strategies as st

from cosim.calibrate.job import load_job
from cosim.campaign.job import load_campaign
from cosim.campaign.sensitivity import load_sensitivity
from cosim.cli import make_parser
from cosim.config import load_config
from cosim.diagnose.job import load_diagnose_job
from cosim.errors import CosimError, ScaleWarning
from cosim.haptic.params import load_arm_params, load_uncertainty_weight, load_user_params, user_params_table
from cosim.tomldoc import key_paths

ROOT = Path(__file__).resolve().parent.parent

# loader -> the shipped examples it reads (the diagnosis: the haptic job, whose Modelica effect checks take
# 0.4 s where the gripper's take 3 s, uncached)
EXAMPLES = {
    "run": ["gripper_static.toml", "gripper_impact_split.toml"],
    "calibrate": ["calibrate_static.toml", "calibrate_contact.toml"],
    "diagnose": ["diagnose_haptic.toml"],
    "campaign": ["campaign_table1.toml"],
    "sensitivity": ["sensitivity_table1.toml"],
}
LOADERS = {"run": load_config, "calibrate": load_job, "diagnose": load_diagnose_job, "campaign": load_campaign,
           "sensitivity": load_sensitivity}
# the shipped files a mutated example names (the campaign's coatings' run configs), linked beside it
_BESIDE = ["gripper_impact.toml", "gripper_impact_p3.toml"]
# a loader whose mutated example names another that is fuzzed too (the sensitivity job's campaign job): its cases
# are written in a subfolder of their own, beside a copy of the shipped file it names
_OWN_FOLDER = {"sensitivity": ("sensitivity", ["campaign_table1.toml"])}

_WORDS = ["plant", "foc", "outer", "F_g", "rate", "x", "0", "signals", "parameters", "class", "path", "kind",
          "campaign", "coatings", "sources", "trials", "P3", "config", "sensitivity", "factors", "set", "low",
          "samples", "C_h"]
_STRINGS = (st.sampled_from(["", "plant.F_g", "plant.nope", "cosim_controllers.foc:FOC", ":FOC", ".foc:FOC", "foc:",
                            "nope.py:X", "../fmus/GripperPlant.fmu", "data/static_paper.csv", "rk4", "none",
                            "static", "frequency", "x.y.z", "ME", "CS", "auto", "\x00", "data/\x00.csv"])
            | st.text(max_size=12))  # a NUL byte: a path the operating system refuses (1 case in 10,000 before)
_NUMBERS = (st.integers(min_value=-2**63, max_value=2**63 - 1)
            | st.floats(allow_nan=True, allow_infinity=True)
            | st.sampled_from([0, -1, 1e15, 1e-300, 1e308, 26600, 1e9, 0.5]))
# TOML's dates and times: a value a user can type where a number is meant
_DATES = st.sampled_from([datetime.date(1979, 5, 27), datetime.datetime(1979, 5, 27, 7, 32), datetime.time(7, 32),
                          datetime.datetime(1979, 5, 27, 7, 32, tzinfo=datetime.timezone.utc)])
_SCALARS = _NUMBERS | st.booleans() | _STRINGS | _DATES
VALUES = st.recursive(_SCALARS, lambda inner: st.lists(inner, max_size=3)
                      | st.dictionaries(st.sampled_from(_WORDS), inner, max_size=3), max_leaves=6)


def toml_value(v):
    """``v`` as a TOML literal (inline tables and arrays for containers)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return "nan" if v != v else ("inf" if v == float("inf") else "-inf" if v == -float("inf") else repr(v))
    if isinstance(v, str):
        return '"' + "".join(c if c.isprintable() and c not in '"\\' else f"\\u{ord(c):04x}" for c in v) + '"'
    if isinstance(v, (datetime.date, datetime.time)):
        return v.isoformat()
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    return "{" + ", ".join(f"{k} = {toml_value(x)}" for k, x in v.items()) + "}"


def dotted(path):
    return ".".join(str(p) for p in path)


@st.composite
def cases(draw, loader):
    """(example name, mutated text, --set overrides) for ``loader`` (a key of :data:`LOADERS`)."""
    name = draw(st.sampled_from(EXAMPLES[loader]))
    text = (ROOT / "examples" / name).read_text(encoding="utf-8")
    lines = text.splitlines()
    keyed = [i for i, line in enumerate(lines) if re.match(r"^\s*[A-Za-z_][\w.]*\s*=", line)]
    for _ in range(draw(st.integers(0, 2))):
        i = draw(st.sampled_from(keyed))
        kind = draw(st.sampled_from(["value", "delete", "duplicate", "rename"]))
        if "=" not in lines[i]:  # deleted by an earlier mutation
            continue
        key = lines[i].split("=", 1)[0]
        if kind == "value":
            lines[i] = f"{key}= {toml_value(draw(VALUES))}"
        elif kind == "delete":
            lines[i] = ""
        elif kind == "duplicate":
            lines.insert(i, lines[i])
        else:
            lines[i] = f"{draw(st.sampled_from(_WORDS))} ={lines[i].split('=', 1)[1]}"
    paths = list(key_paths(tomllib.loads(text)))
    overrides = []
    for _ in range(draw(st.integers(0, 2))):
        kind = draw(st.sampled_from(["existing", "extended", "made-up", "text"]))
        if kind == "text":
            overrides.append(draw(st.text(max_size=20)))
            continue
        path = draw(st.sampled_from(paths)) if kind != "made-up" else ()
        if kind != "existing":
            path += tuple(draw(st.lists(st.sampled_from(_WORDS), min_size=1, max_size=3)))
        overrides.append(f"{dotted(path)}={toml_value(draw(VALUES))}")
    return name, "\n".join(lines) + "\n", overrides


def workspace(tmp, fmus):
    """A folder laid out as the project (examples/, with links to ``fmus`` (GripperPlant, PMSM and Drivetrain
    FMUs), modelica/ and examples/data/), where a mutated example resolves its relative paths as the shipped one."""
    tmp = Path(tmp)
    (tmp / "examples").mkdir(exist_ok=True)
    for link, target in ((tmp / "fmus", Path(fmus)), (tmp / "modelica", ROOT / "modelica"),
                         (tmp / "examples" / "data", ROOT / "examples" / "data")):
        if not link.exists():
            link.symlink_to(target, target_is_directory=True)
    for name in _BESIDE:
        if not (tmp / "examples" / name).exists():
            (tmp / "examples" / name).symlink_to(ROOT / "examples" / name)
    for sub, copies in _OWN_FOLDER.values():
        (tmp / "examples" / sub).mkdir(exist_ok=True)
        for name in copies:  # a copy: a link would let another loader's case write into the shipped file
            shutil.copyfile(ROOT / "examples" / name, tmp / "examples" / sub / name)
        for name in _BESIDE:
            if not (tmp / "examples" / sub / name).exists():
                (tmp / "examples" / sub / name).symlink_to(ROOT / "examples" / name)
    return tmp / "examples"


def check(loader, folder, case):
    """Load ``case`` from ``folder`` with the real loader: "ok" or the name of the CosimError it raised. Any
    other exception propagates."""
    name, text, overrides = case
    path = Path(folder) / _OWN_FOLDER.get(loader, ("",))[0] / name
    path.write_text(text, encoding="utf-8")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ScaleWarning)  # a rate far from the plant's scale: said, not refused
            LOADERS[loader](path, overrides)
    except CosimError as err:
        return type(err).__name__
    return "ok"


# the haptic command: its table loaders (a request of any value), and its sub-commands' arguments (any text)
HAPTIC_LOADERS = {"user": load_user_params, "arm": load_arm_params, "weight": load_uncertainty_weight,
                  "table": user_params_table}
_HAPTIC_ARGS = {"margins": ["--K", "--rate"], "collisions": ["--users", "--K", "--rate"],
                "identify": ["--user", "--position", "--seed"], "arm": ["--seed"]}
_TOKENS = (st.sampled_from(["1", "0", "-1", "13", "14", "nan", "inf", "-inf", "1e400", "1,2", "1,x", "", " 3",
                            "0x10", "1.5", "10", "1e-300"]) | st.text(max_size=8))


@st.composite
def haptic_cases(draw):
    """("loader", name, positional values) or ("arguments", argv): a haptic table request or a command line."""
    if draw(st.booleans()):
        sub = draw(st.sampled_from(sorted(_HAPTIC_ARGS)))
        argv = ["haptic", sub, "--out", "out"]
        for flag in draw(st.lists(st.sampled_from(_HAPTIC_ARGS[sub]), max_size=3)):
            argv += [flag, draw(_TOKENS)]
        return "arguments", argv
    name = draw(st.sampled_from(sorted(HAPTIC_LOADERS)))
    anything = VALUES | st.sampled_from([1, 3, 6, 7, 11, 13, "X", "Z", "nominal", "max", "67ci", 2, 5e-4])
    least, most = {"user": (2, 4), "arm": (1, 2), "weight": (1, 2), "table": (0, 1)}[name]  # required, all
    return "loader", name, tuple(draw(anything) for _ in range(draw(st.integers(least, most))))


def check_haptic(case):
    """Run a haptic case: a loader returns or raises a CosimError ("ok" or its name); arguments parse (their
    numbers then finite and positive where the command needs it) or argparse refuses them (exit status 2). Any
    other exception propagates."""
    if case[0] == "loader":
        try:
            HAPTIC_LOADERS[case[1]](*case[2])
        except CosimError as err:
            return type(err).__name__
        return "ok"
    try:
        args = make_parser().parse_args(case[1])
    except SystemExit as refused:
        assert refused.code == 2
        return "refused"
    for key in ("K", "rate"):
        value = getattr(args, key, 1.0)
        assert math.isfinite(value) and value > 0, (key, value)
    assert getattr(args, "seed", 0) >= 0
    return "ok"


__all__ = ["EXAMPLES", "LOADERS", "VALUES", "cases", "check", "workspace", "toml_value", "haptic_cases",
           "check_haptic", "HAPTIC_LOADERS"]
