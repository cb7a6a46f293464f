"""Effect slots through Modelica's own replaceable/redeclare (issue 27).

The compiler carries ``extends Base(redeclare Block slot(...))``; the baselines with their neutral slots lower to
the same explicit model as the sources before the slots (a copy kept in tests/models/effects/before), and each
effect variant written by a redeclare lowers to the same model as the variant the text edits wrote before (their
``package Diagnosis``, kept in tests/models/effects/before/<Model>_<effect>.mo). "The same model": the same
states, inputs, outputs and tunable parameters with the same defaults, and ``der(x)``, the outputs and the initial
state agreeing to 1e-12 relative at random points.
"""

import warnings
from pathlib import Path

import numpy as np
import pytest

from cosim.compile import lower
from cosim.diagnose.effects import EFFECTS, applicable, write_variant
from cosim.errors import UnsupportedConstructError

ROOT = Path(__file__).resolve().parent.parent
BEFORE = ROOT / "tests" / "models" / "effects" / "before"
SOURCES = {name: ROOT / "modelica" / name / "package.mo" for name in ("Gripper", "Haptic")}
GRIPPER = ["backdrive_efficiency", "load_dependent_friction", "stiction", "cogging", "loadcell_filter",
           "contact_damping", "gear_play", "coating_relaxation"]
VARIANTS = {  # the variants the text edits wrote, saved before the slots
    "Gripper.GripperCurrentDriven": GRIPPER,
    "Gripper.GripperSpeedControlled": GRIPPER,
    "Haptic.Device7": ["hand_mass", "vibration_mode", "loop_delay"],
    "Haptic.Device11": ["vibration_mode", "loop_delay"],
    "Haptic.DeviceArm": ["vibration_mode", "loop_delay"],
}
BASELINES = ["Gripper.GripperCurrentDriven", "Gripper.GripperSpeedControlled", "Gripper.GripperPlant",
             "Gripper.Drivetrain", "Gripper.PMSM", "Haptic.Device7", "Haptic.Device11", "Haptic.DeviceArm",
             "Haptic.Arm"]

TINY = """package T
  partial model FrictionSlot
    input Real v;
    output Real F;
  end FrictionSlot;
  model Coulomb
    extends FrictionSlot;
    parameter Real F_c = 1;
  equation
    F = F_c*tanh(v/1e-3);
  end Coulomb;
  model Bristle
    extends FrictionSlot;
    parameter Real F_c = 1;
    parameter Real F_s = 2;
    Real s(start = 0, fixed = true);
  equation
    der(s) = v - s;
    F = F_c*tanh(v/1e-3) + (F_s - F_c)*s;
  end Bristle;
  model Base
    parameter Real F_cj = 0.5;
    input Real u;
    Real x(start = 0, fixed = true);
    Real v(start = 0, fixed = true);
    replaceable T.Coulomb guide(F_c = F_cj) constrainedby T.FrictionSlot;
  equation
    der(x) = v;
    der(v) = u - guide.F;
    guide.v = v;
  end Base;
  model V
    extends Base(redeclare T.Bristle guide(F_c = F_cj, F_s = F_sj));
    parameter Real F_sj = 3;
  end V;
end T;
"""


def _lower(path, model):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return lower(path, model)


def test_redeclare_in_extends_replaces_the_component(tmp_path):
    (tmp_path / "T").mkdir()
    (tmp_path / "T" / "package.mo").write_text(TINY)
    base, variant = _lower(tmp_path / "T" / "package.mo", "T.Base"), _lower(tmp_path / "T" / "package.mo", "T.V")
    assert [s.name for s in base.states] == ["x", "v"]
    assert [s.name for s in variant.states] == ["x", "v", "guide.s"]
    assert {p.name: p.start for p in variant.parameters} == {"F_cj": 0.5, "F_sj": 3.0}
    # der(v) = u - (F_c tanh(v/1e-3) + (F_s - F_c) s) with F_c = F_cj, F_s = F_sj
    np.testing.assert_allclose(variant.derivatives([0.1, 0.2, 0.3], [1.0]),
                               [0.2, 1 - (0.5 * np.tanh(200.0) + 2.5 * 0.3), 0.2 - 0.3], rtol=1e-14)
    np.testing.assert_allclose(base.derivatives([0.1, 0.2], [1.0]), [0.2, 1 - 0.5 * np.tanh(200.0)], rtol=1e-14)


IGNORED_BY_RUMOCA = {  # each lowered without an error to the model without the redeclare
    "nested": ("  model Outer\n    input Real u;\n    replaceable T.Base b(u = u) constrainedby T.Base;\n  end Outer;\n"
               "  model W\n    extends Outer(b(redeclare T.Bristle guide));\n  end W;\n",
               "a redeclare nested in a component modification"),
    "inherited": ("  model Mid\n    extends Base;\n  end Mid;\n"
                  "  model W\n    extends Mid(redeclare T.Bristle guide);\n  end W;\n",
                  "T.Mid does not itself declare a replaceable guide"),
    "class modifiers": ("  model BaseC\n    input Real v;\n"
                        "    replaceable model G = T.Coulomb constrainedby T.FrictionSlot;\n"
                        "    G guide(v = v);\n  end BaseC;\n"
                        "  model W\n    extends BaseC(redeclare model G = T.Bristle(F_s = 4));\n  end W;\n",
                        "the modifiers of the redeclared class G"),
}


@pytest.mark.parametrize("case", IGNORED_BY_RUMOCA)
def test_redeclare_rumoca_would_ignore_is_rejected_with_file_and_line(tmp_path, case):
    extra, message = IGNORED_BY_RUMOCA[case]
    (tmp_path / "T").mkdir()
    path = tmp_path / "T" / "package.mo"
    path.write_text(TINY.replace("end T;\n", extra + "end T;\n"))
    line = path.read_text().splitlines().index(next(s for s in extra.splitlines() if "redeclare" in s)) + 1
    with pytest.raises(UnsupportedConstructError, match=message) as err:
        _lower(path, "T.W")
    assert f"package.mo:{line}:" in str(err.value)


def _names(variables):
    return [v.name for v in variables]


def assert_same_model(new, old, points=20, seed=0):
    """``new`` and ``old`` are one explicit model up to the order of their variables."""
    for group in ("states", "inputs", "outputs"):
        assert sorted(_names(getattr(new, group))) == sorted(_names(getattr(old, group))), group
    assert {p.name: p.start for p in new.parameters} == {p.name: p.start for p in old.parameters}
    perm = {g: [_names(getattr(new, g)).index(n) for n in _names(getattr(old, g))]
            for g in ("states", "inputs", "outputs", "parameters")}
    rng = np.random.default_rng(seed)
    p_old = old.parameter_values
    x0_old = old.initial_state(p_old)
    for _ in range(points):
        p = p_old * (1 + 0.05 * rng.standard_normal(len(p_old)))
        x = old.initial_state(p) + 1e-3 * rng.standard_normal(len(x0_old))
        u = rng.standard_normal(len(old.inputs))
        t = rng.uniform(0, 1)
        x_new, u_new, p_new = (np.empty(len(a)) for a in (x, u, p))
        x_new[perm["states"]], u_new[perm["inputs"]], p_new[perm["parameters"]] = x, u, p
        np.testing.assert_allclose(new.initial_state(p_new)[perm["states"]], old.initial_state(p), rtol=1e-12,
                                   atol=1e-300)
        np.testing.assert_allclose(new.derivatives(x_new, u_new, p_new, t)[perm["states"]],
                                   old.derivatives(x, u, p, t), rtol=1e-12, atol=1e-300)
        np.testing.assert_allclose(new.output_values(x_new, u_new, p_new, t)[perm["outputs"]],
                                   old.output_values(x, u, p, t), rtol=1e-12, atol=1e-300)


@pytest.mark.parametrize("model", BASELINES)
def test_baseline_with_neutral_slots_is_the_model_before_the_slots(model):
    package = model.split(".")[0]
    assert_same_model(_lower(SOURCES[package], model), _lower(BEFORE / package / "package.mo", model))


@pytest.mark.parametrize("model, effect", [(m, e) for m, effects in VARIANTS.items() for e in effects])
def test_variant_by_redeclare_is_the_variant_the_text_edits_wrote(model, effect, tmp_path):
    package, _, short = model.partition(".")
    old_text = (BEFORE / package / "package.mo").read_text(encoding="utf-8")
    snippet = (BEFORE / f"{short}_{effect}.mo").read_text(encoding="utf-8")
    head, end, tail = old_text.rpartition(f"end {package};")
    old_path = tmp_path / "before" / package / "package.mo"
    old_path.parent.mkdir(parents=True)
    old_path.write_text(head + snippet + end + tail, encoding="utf-8")
    new_path, name = write_variant(SOURCES[package], model, EFFECTS[effect], tmp_path / "after")
    assert name == f"{package}.Diagnosis.{short}_{effect}"
    assert_same_model(_lower(new_path, name), _lower(old_path, name))


@pytest.mark.parametrize("model", VARIANTS)
def test_effects_that_apply_are_the_saved_variants(model):
    assert applicable(SOURCES[model.split(".")[0]].read_text(encoding="utf-8"), model) == VARIANTS[model]
