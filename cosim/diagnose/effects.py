"""The library of candidate missing effects and the Modelica variants that add them to a baseline model.

Each effect fills an *effect slot* of the baseline: a ``replaceable`` component whose default is today's law or a
block that does nothing (``modelica/Gripper/package.mo``: drag, mesh, guide, lfric, contact inside
``Gripper.DrivetrainMechanics``, cog and lc in the current- and speed-driven models; ``modelica/Haptic/package.mo``:
delay, mode in every device, hand in ``Haptic.Device7``). An effect is data: the slot, the block of
``Gripper.Effects``/``Haptic.Effects`` that replaces its default, how that block's parameters bind to the effect's
parameters. Its variant of ``Pkg.Model`` is a model ``Pkg.Diagnosis.<Model>_<effect>`` that extends the baseline
with a ``redeclare`` of the slot (and declares the effect's parameters at its top level, where the fit tunes them).
A slot inside a component (``drive.guide``) is redeclared in a subclass of the component's class,
``Pkg.Diagnosis.<Class>_<effect>``, which the variant puts in place of the (replaceable) component: rumoca ignores
a ``redeclare`` nested in a component's modifier of an ``extends`` clause (docs/compiler.md). The variants are
appended to a copy of the package in a build folder, so the baseline source is untouched and ``diff`` of the two
files is the readable change (``OUT/variant.diff``).

Whether an effect applies is a structural query on the model: does it have the slot (or, for an effect that only
frees parameters, those parameters). :class:`~cosim.errors.EffectSlotError` says why an effect does not fit.
"""

import re
from dataclasses import dataclass
from pathlib import Path

from cosim.modelica_text import class_chain, replaceables
from cosim.errors import ConfigError, EffectSlotError

__all__ = ["EffectParameter", "Effect", "Slot", "EFFECTS", "effect_names", "applicable", "forms_not_offered",
           "get_effect", "slots", "write_variant", "variant_text"]


@dataclass(frozen=True)
class EffectParameter:
    """One physical parameter of an effect: declared in the variant, fitted by the diagnosis.

    ``start`` is a number or the name of a baseline parameter whose fitted value starts the fit."""

    name: str
    start: object
    lower: float
    upper: float
    unit: str
    description: str
    starts: tuple = ()  # other start values, each fitted in turn (the cost is multi-modal in it): the best is kept


@dataclass(frozen=True)
class Effect:
    """A candidate effect.

    Attributes
    ----------
    name : str
        Identifier used in jobs and in ``diagnosis.json``.
    title : str
        One line: what physics the effect adds.
    parameters : tuple of EffectParameter
        Declared at the variant's top level (tunable FMU parameters) and fitted.
    slot : str
        Path of the replaceable component the effect redeclares (``"cog"``, ``"drive.guide"``); empty for an effect
        that only frees existing parameters.
    replacement : str
        Full name of the block that takes the slot's place; it extends the slot's constraining interface.
    bindings : tuple of (str, str)
        Modifiers of the replacement on top of the slot's own: (block parameter, effect parameter).
    signature : str
        Where and how it shows in a residual (for the report).
    frees : tuple of (str, float, float)
        Existing baseline parameters the effect frees, with bounds (parameter-only effects).
    shown_by : str
        The experiment that shows it (docs/guide/diagnose.md, "Which experiment shows which effect").
    shown_in : str
        The shipped example job of that experiment (a file under ``examples/``), "" when none ships.
    law : str
        For a *form* (a law of another form in place of one the baseline already has, not added physics): the law
        it replaces, e.g. "the finger contact's law"; "" for an effect.
    """

    name: str
    title: str
    parameters: tuple
    slot: str = ""
    replacement: str = ""
    bindings: tuple = ()
    signature: str = ""
    frees: tuple = ()
    shown_by: str = "no experiment is known to show it"
    shown_in: str = ""
    law: str = ""

    @property
    def is_form(self):
        """Whether the candidate changes the form of a law the baseline has (else it adds an effect)."""
        return bool(self.law)


@dataclass(frozen=True)
class Slot:
    """A replaceable component of a model: its default class, constraining class and modifiers."""

    default: str
    constraint: str
    modifiers: tuple  # (name, expression) of the declaration's modification


def _same(*names):
    return tuple((n, n) for n in names)


def _drag_form(name, block, tag, title, signature):
    """A form of the drive's friction (slot drive.drag): its breakaway torque T_s<tag>, from the fitted T_c0, and its
    Stribeck speed w_s<tag> fitted; shown at slow, steady motor speeds."""
    return Effect(
        name=name, title=title,
        parameters=(EffectParameter(f"T_s{tag}", "T_c0", 0.0, 0.05, "N.m", f"Breakaway friction torque of the drive "
                                    f"({name})"),
                    EffectParameter(f"w_s{tag}", 0.5, 0.01, 10.0, "rad/s", f"Stribeck speed of the drive's friction "
                                    f"({name})")),
        slot="drive.drag", replacement=block, bindings=(("T_s", f"T_s{tag}"), ("w_s", f"w_s{tag}")),
        signature=signature, shown_by="speed run: slow speeds under a PI speed loop, current and encoder at 1 kHz",
        shown_in="diagnose_speed.toml", law="the drive's friction law (the motor-side drag)")


EFFECTS = {
    "backdrive_efficiency": Effect(
        name="backdrive_efficiency",
        title="gear efficiency by direction of power flow: eta_g driving, eta_b back-driven",
        parameters=(EffectParameter("eta_b", "eta_g", 0.2, 1.0, "1",
                                    "Gear mesh efficiency when the load back-drives the motor"),),
        slot="drive.mesh", replacement="Gripper.Effects.DirectionalMeshEfficiency", bindings=_same("eta_b"),
        signature="release branch: the force held on the way down differs, the rising branch fits",
        shown_by="static current staircase, force measured", shown_in="diagnose_static.toml",
    ),
    "load_dependent_friction": Effect(
        name="load_dependent_friction",
        title="jaw-guide friction proportional to the gripping force, held at rest",
        parameters=(EffectParameter("mu_F", 0.02, 0.0, 0.5, "1", "Guide friction force per unit gripping force"),),
        slot="drive.lfric", replacement="Gripper.Effects.LoadDependentFriction", bindings=_same("mu_F"),
        signature="hysteresis that scales with the force: both branches' slopes change",
        shown_by="current-step impact, force and encoder", shown_in="diagnose_impact.toml",
    ),
    "stiction": Effect(
        name="stiction",
        title="stiction with a Stribeck drop in the jaw guides (elasto-plastic bristle), replacing the creeping "
              "Coulomb guide",
        parameters=(EffectParameter("F_sj", 1.0, 0.01, 20.0, "N", "Static (breakaway) guide friction per jaw",
                                    starts=(4.0, 10.0)),  # below the rack force at a restart the cost is flat
                    EffectParameter("F_cj", "F_cj", 0.0, 10.0, "N", "Sliding guide friction per jaw")),
        slot="drive.guide", replacement="Gripper.Effects.StribeckGuide", bindings=(("F_s", "F_sj"),),
        signature="held force offsets after stops, first motion delayed (breakaway), plateaus",
        shown_by="slide: the jaws stop and restart against the guides, current and encoder at 1 kHz",
    ),
    "cogging": Effect(
        name="cogging",
        title="motor cogging torque periodic in the rotor angle",
        parameters=(EffectParameter("T_cog", 2e-3, 0.0, 0.05, "N.m", "Cogging torque amplitude"),
                    EffectParameter("phase_cog", 0.0, -3.1416, 3.1416, "rad", "Cogging phase at theta = 0",
                                    starts=(-2.0944, 2.0944))),
        slot="cog", replacement="Gripper.Effects.CoggingTorque",
        bindings=(("T_cog", "T_cog"), ("phase", "phase_cog")),
        signature="force errors that vary from step to step with the rotor's rest angle",
        shown_by="speed run: slow speeds under a PI speed loop, current and encoder at 1 kHz",
        shown_in="diagnose_speed.toml",
    ),
    "loadcell_filter": Effect(
        name="loadcell_filter",
        title="load-cell first-order low-pass and offset",
        parameters=(EffectParameter("tau_lc", 0.01, 1e-4, 1.0, "s", "Load-cell low-pass time constant"),
                    EffectParameter("F_off", 0.0, -20.0, 20.0, "N", "Load-cell offset")),
        slot="lc", replacement="Gripper.Effects.LoadCell", bindings=_same("tau_lc", "F_off"),
        signature="a bias where the true force is zero, a lag after each step",
        shown_by="static current staircase, force measured", shown_in="diagnose_static.toml",
    ),
    "contact_damping": Effect(
        name="contact_damping",
        title="Hunt-Crossley contact damping: a damping force lambda_hc*F_s*v proportional to the elastic force",
        parameters=(EffectParameter("lambda_hc", 0.05, 0.0, 5.0, "s/m",
                                    "Hunt-Crossley damping per unit elastic contact force", starts=(1.0,)),),
        slot="drive.contact", replacement="Gripper.Effects.HuntCrossleyContact", bindings=_same("lambda_hc"),
        signature="impact peak and rebound: dissipation that grows with penetration",
        shown_by="current-step impact, force and encoder", shown_in="diagnose_impact.toml",
    ),
    "gear_play": Effect(
        name="gear_play",
        title="gear play magnitude (frees the existing play parameter; no new equations)",
        parameters=(),
        frees=(("play", 0.0, 0.1),),
        signature="impact peak and the delay of first force after a reversal",
        shown_by="current-step impact, force and encoder", shown_in="diagnose_impact.toml",
    ),
    "coating_relaxation": Effect(
        name="coating_relaxation",
        title="viscoelastic finger coating: a Maxwell branch k_rel*k_P with time constant tau_rel in parallel with "
              "the coating's elastic element (standard linear solid)",
        parameters=(EffectParameter("k_rel", 0.5, 0.0, 10.0, "1",
                                    "Maxwell branch stiffness per unit coating first-region stiffness"),
                    EffectParameter("tau_rel", 0.1, 0.02, 2.0, "s",
                                    "Coating relaxation time constant (slower than the impact, else it is damping)")),
        slot="drive.contact", replacement="Gripper.Effects.RelaxingCoatingContact",
        bindings=_same("k_rel", "tau_rel"),
        signature="coated fingers: the force held after the impact decays with tau_rel (bare fingers: no change)",
        shown_by="current-step impact on coated fingers, force and encoder", shown_in="diagnose_impact.toml",
    ),
    # Forms: laws of another form in the slot of a law the baseline has (Gripper.Forms; sources and ranges in
    # the blocks' comments and docs/models/gripper.md). Ranges from each form's physics, not from a measurement.
    "power_law_coating": Effect(
        name="power_law_coating",
        title="a Hertz-type power law F = F_lim*(delta_c/d_lim)^n_c for the coating's first region instead of the "
              "linear one",
        parameters=(EffectParameter("n_c", 1.0, 1.0, 3.0, "1", "Exponent of the coating's first region",
                                    starts=(1.5, 2.2)),),
        slot="drive.contact", replacement="Gripper.Forms.PowerLawCoatingContact", bindings=_same("n_c"),
        signature="coated fingers: the force rises later and steeper in the impact (bare fingers: no change)",
        shown_by="current-step impact on coated fingers, force and encoder", shown_in="diagnose_rounds.toml",
        law="the finger contact's elastic law",
    ),
    "hunt_crossley_contact": Effect(
        name="hunt_crossley_contact",
        title="Hunt and Crossley's contact: F = F_s*(1 + lambda_c*v) with a power-law coating, no linear damping",
        parameters=(EffectParameter("n_hc", 1.5, 1.0, 3.0, "1", "Exponent of the coating's first region",
                                    starts=(1.0,)),
                    EffectParameter("lambda_c", 6.0, 0.0, 1000.0, "s/m", "Hunt-Crossley damping per unit elastic "
                                    "force", starts=(60.0,))),
        slot="drive.contact", replacement="Gripper.Forms.HuntCrossleyContact",
        bindings=(("n_c", "n_hc"), ("lambda_c", "lambda_c")),
        signature="impact peak and rebound: no damping force at first touch, dissipation that grows with the force",
        shown_by="current-step impact on coated fingers, force and encoder", shown_in="diagnose_rounds.toml",
        law="the finger contact's law (elastic and dissipative)",
    ),
    "hysteretic_coating": Effect(
        name="hysteretic_coating",
        title="a rate-independent (Bouc-Wen) hysteresis of the contact: a fraction a_h of the force carried by a "
              "hysteretic element yielding at z_y",
        parameters=(EffectParameter("a_h", 0.0, 0.0, 1.0, "1", "Fraction of the contact force that is hysteretic",
                                    starts=(0.3,)),
                    EffectParameter("z_h", 1e-4, 1e-6, 1e-3, "m", "Yield penetration of the hysteretic element",
                                    starts=(1e-5,))),
        slot="drive.contact", replacement="Gripper.Forms.HystereticCoatingContact",
        bindings=(("a_h", "a_h"), ("z_y", "z_h")),
        signature="the force held after the impact lower than the loading path gives, at any rate",
        shown_by="current-step impact on coated fingers, force and encoder", shown_in="diagnose_rounds.toml",
        law="the finger contact's elastic law",
    ),
    "stribeck_guide": Effect(
        name="stribeck_guide",
        title="guide friction on a Stribeck curve (static level F_sg falling to F_c above v_sg), memoryless",
        parameters=(EffectParameter("F_sg", "F_cj", 0.0, 20.0, "N", "Static guide friction level per jaw",
                                    starts=(1.0,)),
                    EffectParameter("v_sg", 1e-3, 1e-5, 1e-2, "m/s", "Stribeck velocity of the guides")),
        slot="drive.guide", replacement="Gripper.Forms.StribeckCurveGuide", bindings=_same("F_sg", "v_sg"),
        signature="more friction at low speed: restarts that need more current, slow motion damped",
        shown_by="slide: the jaws stop and restart against the guides, current and encoder at 1 kHz",
        law="the jaw guides' friction law",
    ),
    "dahl_guide": Effect(
        name="dahl_guide",
        title="Dahl's bristle friction in the guides: a presliding spring F_c/x_dg that slides at F_c",
        parameters=(EffectParameter("x_dg", 1e-5, 1e-7, 1e-4, "m", "Presliding displacement of the guides",
                                    starts=(1e-6,)),),
        slot="drive.guide", replacement="Gripper.Forms.DahlGuide", bindings=(("x_d", "x_dg"),),
        signature="friction that builds up over a distance after each reversal, not at once",
        shown_by="slide: the jaws stop and restart against the guides, current and encoder at 1 kHz",
        law="the jaw guides' friction law",
    ),
    "stribeck_drag": _drag_form(
        "stribeck_drag", "Gripper.Forms.StribeckDrag", "d",
        "the drive's friction on a Stribeck curve: breakaway T_sd falling to T_c0 above w_sd, held by the bristle",
        "more friction at low motor speed: slow motion takes more current than fast"),
    "lugre_drag": _drag_form(
        "lugre_drag", "Gripper.Forms.LuGreDrag", "l",
        "LuGre friction in the drive: a bristle plastic from the first motion (no elastic range), its level on a "
        "Stribeck curve from T_sl to T_c0 above w_sl",
        "a held shaft creeps under a varying load; more friction at low motor speed"),
    "load_exponent_mesh": Effect(
        name="load_exponent_mesh",
        title="a gear loss that grows as the transmitted torque to the power n_L (an efficiency that varies with "
              "the load; eta_g at 0.13 N.m) instead of in proportion",
        parameters=(EffectParameter("n_L", 1.0, 0.5, 2.0, "1", "Power of the transmitted torque the gear loss "
                                    "grows with"),),
        slot="drive.mesh", replacement="Gripper.Forms.LoadExponentMeshLoss", bindings=_same("n_L"),
        signature="both branches of the staircase curve: the force is not linear in the current",
        shown_by="static current staircase, force measured", shown_in="diagnose_static.toml",
        law="the gear mesh's loss law",
    ),
    # The haptic device + user (Haptic.Device7 and the other Haptic.Device* models).
    "hand_mass": Effect(
        name="hand_mass",
        title="the user's hand mass mh held by kh, bh behind the skin ks, bs (7 -> 11-parameter user, seed 000)",
        parameters=(EffectParameter("mh", 0.006, 1e-4, 0.1, "kg.m2", "Hand inertia at the phi axis"),
                    EffectParameter("kh", 3.0, 0.05, 100.0, "N.m/rad", "Stiffness of the hand to the user's reference",
                                    starts=(1.0, 10.0)),
                    EffectParameter("bh", 0.2, 1e-3, 3.0, "N.m.s/rad", "Damping of the hand to the user's reference"),
                    EffectParameter("b2", 0.02, 0.0, 0.5, "N.m.s/rad", "Viscous friction of m2 to ground")),
        slot="hand", replacement="Haptic.Effects.HandMass", bindings=_same("mh", "kh", "bh", "b2"),
        signature="below ~20 Hz: a second pole/zero pair (the hand's mode) the lumped m2 on ks, bs cannot shape",
        shown_by="haptic frequency response", shown_in="diagnose_haptic.toml",
    ),
    "vibration_mode": Effect(
        name="vibration_mode",
        title="a second device vibration mode: an inertia m3 hung on the motor-side inertia m1 by k3, b3",
        parameters=(EffectParameter("m3", 5e-4, 1e-5, 5e-3, "kg.m2", "Modal inertia of the second mode"),
                    EffectParameter("k3", 70.0, 1.0, 2000.0, "N.m/rad", "Modal stiffness of the second mode",
                                    starts=(12.0, 30.0, 160.0)),
                    EffectParameter("b3", 0.01, 1e-5, 0.5, "N.m.s/rad", "Modal damping of the second mode")),
        slot="mode", replacement="Haptic.Effects.SideMode", bindings=_same("m3", "k3", "b3"),
        signature="a narrow antiresonance/resonance pair near sqrt(k3/m3), a phase wiggle there",
        shown_by="haptic frequency response", shown_in="diagnose_haptic.toml",
    ),
    "loop_delay": Effect(
        name="loop_delay",
        title="a pure delay T_d of the torque command (computation and amplifier), third-order Pade approximation",
        parameters=(EffectParameter("T_d", 1e-3, 1e-5, 5e-3, "s", "Delay of the torque command",
                                    starts=(0.3e-3, 3e-3)),),
        slot="delay", replacement="Haptic.Effects.PadeDelay", bindings=(("T", "T_d"),),
        signature="phase lag growing linearly with frequency (360 T_d deg/Hz), magnitude unchanged",
        shown_by="haptic frequency response", shown_in="diagnose_haptic.toml",
    ),
}


def effect_names():
    """Identifiers of the implemented effects, in library order."""
    return list(EFFECTS)


def get_effect(name):
    """The :class:`Effect` called ``name``; a ConfigError lists the library when it is unknown.

    Parameters
    ----------
    name : str
        An effect identifier, e.g. ``"cogging"``.
    """
    if name in EFFECTS:
        return EFFECTS[name]
    raise ConfigError(f"unknown effect {name!r}; implemented: {', '.join(EFFECTS)}")


# -- the structural query: the model's replaceable components -----------------------------------------------
def slots(source_text, model):
    """The effect slots of ``model``: path -> :class:`Slot`, the replaceable components declared in the model's
    own class and in the classes of those components (``drive.guide``).

    Only the class's own declarations count: rumoca 0.10.2 ignores a ``redeclare`` of an element that the
    extended class inherits (docs/compiler.md), so a slot of a base class cannot be filled by a variant.

    Raises
    ------
    ConfigError
        ``model`` is not a class of the source.
    """
    found = {}
    for name, default, constraint, mods in replaceables(source_text, model):
        found[name] = Slot(default, constraint, mods)
        for path, inner in slots(source_text, default).items():
            found[f"{name}.{path}"] = inner
    return found


def _parameter(source_text, model, name):
    """The declaration default of parameter ``name`` of ``model`` (or of a class it extends): a float, the text of
    a non-numeric default, "" when it has none; None when the model does not declare it."""
    for _, own in class_chain(source_text, model):
        match = re.search(rf"\bparameter\s+(?:Real|Integer|Boolean)\s+{re.escape(name)}\b(?:\([^)]*\))?"
                          rf"\s*(?:=\s*([^\"\n;]+?))?\s*(?:\"|;)", own)
        if match:
            value = (match.group(1) or "").strip()
            try:
                return float(value)
            except ValueError:
                return value
    return None


def _fits(source_text, model, effect, model_slots):
    """Whether ``effect`` applies to ``model``; EffectSlotError when its slot exists but does not take it."""
    if not effect.slot:
        return all(_parameter(source_text, model, name) is not None for name, _, _ in effect.frees)
    slot = model_slots.get(effect.slot)
    if slot is None:
        return False
    bases = [name for name, _ in class_chain(source_text, effect.replacement)]
    if slot.constraint not in bases:
        raise EffectSlotError(f"effect {effect.name!r}: slot {effect.slot} of {model} is constrained by "
                              f"{slot.constraint}; the effect's block {effect.replacement} extends "
                              f"{', '.join(bases[1:]) or 'nothing'}")
    return True


def applicable(source_text, model, forms=False):
    """Identifiers of the implemented effects that apply to ``model`` of the Modelica ``source_text`` (it has
    their slot), in library order; with ``forms``, the forms that apply (:attr:`Effect.is_form`) instead.

    Raises
    ------
    ConfigError
        ``model`` is not in the source.
    EffectSlotError
        A slot of the model does not take the block of the effect that names it.
    """
    model_slots = slots(source_text, model)
    return [name for name, effect in EFFECTS.items()
            if effect.is_form == forms and _fits(source_text, model, effect, model_slots)]


def forms_not_offered(source_text, model, offered=(), added=()):
    """The forms that apply to ``model`` and are neither ``offered`` nor ``added`` (earlier findings), less those
    whose slot an ``added`` candidate fills, grouped by the law they replace: {law: [form, ...]}, library order."""
    filled = {EFFECTS[n].slot for n in added}
    left = {}
    for name in applicable(source_text, model, forms=True):
        if name not in offered and name not in added and EFFECTS[name].slot not in filled:
            left.setdefault(EFFECTS[name].law, []).append(name)
    return left


# -- the variant's text -----------------------------------------------------------------------------------------
def _declarations(source_text, owner, effect, known_in):
    """Declarations of the effect's parameters that class ``known_in`` does not declare, and their names."""
    lines, names = [], []
    for p in effect.parameters:
        if _parameter(source_text, known_in, p.name) is not None:
            continue
        default = p.start
        if not isinstance(default, (int, float)):
            default = _parameter(source_text, owner, p.start)
            if not isinstance(default, float):
                raise EffectSlotError(f"effect parameter {p.name} starts from {p.start!r}, which {owner} does not "
                                      f"declare with a numeric default")
        lines.append(f'    parameter Real {p.name}(unit = "{p.unit}") = {default} "{p.description} '
                     f'({"form" if effect.is_form else "effect"} {effect.name})";\n')
        names.append(p.name)
    return lines, names


def _model(name, description, base, modifications, declarations):
    """A model extending ``base`` with a ``redeclare`` per (component declaration, modifiers) of
    ``modifications``."""
    heads = [f"redeclare {component}({', '.join(f'{k} = {v}' for k, v in modifiers)})"
             for component, modifiers in modifications]
    extends = f"    extends {base}({', '.join(heads)});\n" if heads else f"    extends {base};\n"
    return f'  model {name} "{description}"\n{extends}{"".join(declarations)}  end {name};\n'


def _merge(modifiers, bindings):
    bound = dict(bindings)
    return tuple((k, v) for k, v in modifiers if k not in bound) + tuple(bindings)


def _as_effects(effects):
    """One Effect or a sequence of them, as a tuple; two in one slot are an EffectSlotError."""
    effects = (effects,) if isinstance(effects, Effect) else tuple(effects)
    taken = {}
    for e in effects:
        if e.slot and e.slot in taken:
            raise EffectSlotError(f"effects {taken[e.slot]!r} and {e.name!r} both fill slot {e.slot}: a variant "
                                  "takes one block per slot")
        taken[e.slot] = e.name
    return effects


def variant_text(source_text, model, effects):
    """The Modelica source of ``Pkg.Model`` with ``effects`` added (one :class:`Effect` or several, each in its own
    slot): (variant model name, full package text).

    The variant (and the subclass of each component class whose slots it fills) go into a sub-package
    ``Diagnosis`` appended to the package; its name joins the effects' names.

    Raises
    ------
    ConfigError
        ``model`` is not a top-level model ``Pkg.Model`` of the source.
    EffectSlotError
        An effect does not apply to ``model`` (no such slot or parameter), with the reason, or two fill one slot.
    """
    effects = _as_effects(effects)
    package, _, short = model.rpartition(".")
    if not package or "." in package:
        raise ConfigError(f"model {model!r}: the diagnosis writes variants of top-level models Pkg.Model")
    model_slots = slots(source_text, model)
    for effect in effects:
        if not _fits(source_text, model, effect, model_slots):
            what = f"slot {effect.slot}" if effect.slot else "parameter " + ", ".join(n for n, _, _ in effect.frees)
            raise EffectSlotError(f"effect {effect.name!r} does not apply to {model}: it has no {what} "
                                  f"(its slots: {', '.join(model_slots) or 'none'})")
    tag = "_".join(e.name for e in effects)
    said = f"effect {tag}" if len(effects) == 1 else "effects " + ", ".join(e.name for e in effects)
    blocks, top, top_decls, inner = [], [], [], {}  # inner: component -> (redeclares, declarations, passed)
    for effect in (e for e in effects if e.slot):
        outer, _, leaf = effect.slot.rpartition(".")
        redeclare = (f"{effect.replacement} {leaf}", _merge(model_slots[effect.slot].modifiers, effect.bindings))
        top_decls += _declarations(source_text, model, effect, model)[0]
        if not outer:
            top.append(redeclare)
            continue
        redeclares, decls, passed = inner.setdefault(outer, ([], [], []))
        redeclares.append(redeclare)
        more, names = _declarations(source_text, model, effect, model_slots[outer].default)
        decls += more
        passed += names
    for outer, (redeclares, decls, passed) in inner.items():  # a slot in a component: redeclared in a subclass
        parent = model_slots[outer]
        name = f"{parent.default.rpartition('.')[2]}_{tag}"
        blocks.append(_model(name, f"{parent.default} with {said}", parent.default, redeclares, decls))
        top.append((f"{package}.Diagnosis.{name} {outer}", _merge(parent.modifiers, _same(*passed))))
    blocks.append(_model(f"{short}_{tag}", f"{model} with {said}", model, top, top_decls))
    body = "".join("".join("  " + line if line.strip() else line for line in b.splitlines(keepends=True))
                   for b in blocks)
    plus = "one effect" if len(effects) == 1 else "effects"
    sub = (f'  package Diagnosis "Model variants written by cosim diagnose: the baseline plus {plus} '
           f'(docs/guide/diagnose.md)"\n{body}  end Diagnosis;\n')
    end = f"end {package};"
    if end not in source_text:
        raise ConfigError(f"the Modelica source does not end with `{end}`")
    head, _, tail = source_text.rpartition(end)
    return f"{package}.Diagnosis.{short}_{tag}", head + sub + end + tail


def write_variant(source, model, effect, folder):
    """Write the package with the variant of ``model`` that adds ``effect`` (an :class:`Effect` or several) to
    ``folder/<Pkg>/package.mo``.

    The folder gets only this one package, as the compiler front end loads every ``.mo`` of a directory.

    Parameters
    ----------
    source : str or Path
        The baseline's package file.
    model : str
        The baseline, ``Pkg.Model``.
    effect : Effect or sequence of Effect
        What to add (each in its own slot).
    folder : str or Path
        Where the package is written.

    Returns
    -------
    tuple
        (path of the written file, variant model name).
    """
    source = Path(source)
    name, text = variant_text(source.read_text(encoding="utf-8"), model, effect)
    out = Path(folder) / source.parent.name / source.name
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text, encoding="utf-8")
    return out, name
