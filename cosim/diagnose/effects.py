"""The library of candidate missing effects and the Modelica variants that add them to a baseline model.

Each effect is a documented Modelica addition: its physics lives in a block of ``Gripper.Effects``
(``modelica/Gripper/package.mo``) or ``Haptic.Effects`` (``modelica/Haptic/package.mo``: hand mass, second
vibration mode, loop delay, wired into ``Haptic.Device7``); what this module adds is the *wiring*. For a baseline such as
``Gripper.GripperCurrentDriven`` it writes a variant model ``Gripper.Diagnosis.<Model>_<effect>`` (and, when the
effect sits inside the drivetrain, a copy ``Gripper.Diagnosis.DrivetrainMechanics_<effect>``) by a few textual
edits of the baseline's own source: new parameter declarations, a component swapped or added, one equation
changed. The variant is appended to a copy of the package in a build folder, so the baseline source is untouched
and ``diff`` of the two files is the readable change (``OUT/variant.diff``).

An edit that does not find its anchor in the baseline means the effect does not apply to that model: a
:class:`~cosim.errors.ConfigError` names the effect, the model and the missing text.
"""

import re
from dataclasses import dataclass, field
from pathlib import Path

from cosim.errors import ConfigError

__all__ = ["Effect", "EFFECTS", "effect_names", "applicable", "get_effect", "write_variant",
           "variant_text"]


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
    drive : tuple of (str, str)
        Text replacements inside the copy of ``Gripper.DrivetrainMechanics`` (empty: the drivetrain is reused).
    drive_parameters : tuple of str
        Parameters passed down to the drivetrain copy (``drive(name = name, ...)``).
    top : tuple of (str, str)
        Text replacements inside the copy of the baseline model.
    signature : str
        Where and how it shows in a residual (for the report).
    """

    name: str
    title: str
    parameters: tuple
    drive: tuple = ()
    drive_parameters: tuple = ()
    top: tuple = ()
    signature: str = ""
    frees: tuple = field(default=())  # existing baseline parameters the effect frees (parameter-only effects)


_DRIVE_ANCHOR = "Gripper.DrivetrainMechanics drive("

EFFECTS = {
    "backdrive_efficiency": Effect(
        name="backdrive_efficiency",
        title="gear efficiency by direction of power flow: eta_g driving, eta_b back-driven",
        parameters=(EffectParameter("eta_b", "eta_g", 0.2, 1.0, "1",
                                    "Gear mesh efficiency when the load back-drives the motor"),),
        drive=(("Gripper.Components.MeshEfficiency mesh(eta = eta_g,",
                "Gripper.Effects.DirectionalMeshEfficiency mesh(eta = eta_g, eta_b = eta_b,"),),
        drive_parameters=("eta_b",),
        signature="release branch: the force held on the way down differs, the rising branch fits",
    ),
    "load_dependent_friction": Effect(
        name="load_dependent_friction",
        title="jaw-guide friction proportional to the gripping force, held at rest",
        parameters=(EffectParameter("mu_F", 0.02, 0.0, 0.5, "1", "Guide friction force per unit gripping force"),),
        drive=(("Gripper.Components.RegularisedCoulomb guide(F_c = F_cj, v_s = v_s) \"Guide Coulomb friction\";",
                "Gripper.Components.RegularisedCoulomb guide(F_c = F_cj, v_s = v_s) \"Guide Coulomb friction\";\n"
                "    Gripper.Effects.LoadDependentFriction lfric(mu_F = mu_F) \"Guide friction proportional to the "
                "gripping force\";"),
               ("jaw.F = rack.F - grease.F - guide.F - contact.F;",
                "lfric.v = jaw.v;\n    lfric.F_n = contact.F;\n"
                "    jaw.F = rack.F - grease.F - guide.F - contact.F - lfric.F;")),
        drive_parameters=("mu_F",),
        signature="hysteresis that scales with the force: both branches' slopes change",
    ),
    "stiction": Effect(
        name="stiction",
        title="stiction with a Stribeck drop in the jaw guides (elasto-plastic bristle), replacing the creeping Coulomb guide",
        parameters=(EffectParameter("F_sj", 1.0, 0.01, 20.0, "N", "Static (breakaway) guide friction per jaw",
                                    starts=(4.0, 10.0)),  # below the rack force at a restart the cost is flat
                    EffectParameter("F_cj", "F_cj", 0.0, 10.0, "N", "Sliding guide friction per jaw")),
        drive=(("Gripper.Components.RegularisedCoulomb guide(F_c = F_cj, v_s = v_s)",
                "Gripper.Effects.StribeckGuide guide(F_c = F_cj, F_s = F_sj)"),),
        drive_parameters=("F_sj",),
        signature="held force offsets after stops, first motion delayed (breakaway), plateaus",
    ),
    "cogging": Effect(
        name="cogging",
        title="motor cogging torque periodic in the rotor angle",
        parameters=(EffectParameter("T_cog", 2e-3, 0.0, 0.05, "N.m", "Cogging torque amplitude"),
                    EffectParameter("phase_cog", 0.0, -3.1416, 3.1416, "rad", "Cogging phase at theta = 0",
                                    starts=(-2.0944, 2.0944))),
        top=(("(J_r + J_g)*der(w) = k_t*i_ref - B_r*w - drive.tau_load;",
              "cog.theta = phi;\n    (J_r + J_g)*der(w) = k_t*i_ref - B_r*w - drive.tau_load - cog.tau;"),
             ("  equation\n    der(phi) = w;",
              "  Gripper.Effects.CoggingTorque cog(T_cog = T_cog, phase = phase_cog) \"Motor cogging\";\n"
              "  equation\n    der(phi) = w;")),
        signature="force errors that vary from step to step with the rotor's rest angle",
    ),
    "loadcell_filter": Effect(
        name="loadcell_filter",
        title="load-cell first-order low-pass and offset",
        parameters=(EffectParameter("tau_lc", 0.01, 1e-4, 1.0, "s", "Load-cell low-pass time constant"),
                    EffectParameter("F_off", 0.0, -20.0, 20.0, "N", "Load-cell offset")),
        top=(("    F_g = drive.F_g;",
              "    lc.F = drive.F_g;\n    F_g = lc.F_meas;"),
             ("  equation\n    der(phi) = w;",
              "  Gripper.Effects.LoadCell lc(tau_lc = tau_lc, F_off = F_off) \"Load-cell dynamics and offset\";\n"
              "  equation\n    der(phi) = w;")),
        signature="a bias where the true force is zero, a lag after each step",
    ),
    "contact_damping": Effect(
        name="contact_damping",
        title="Hunt-Crossley contact damping: a damping force lambda_hc*F_s*v proportional to the elastic force",
        parameters=(EffectParameter("lambda_hc", 0.05, 0.0, 5.0, "s/m",
                                    "Hunt-Crossley damping per unit elastic contact force", starts=(1.0,)),),
        drive=(("Gripper.Components.FingerContact contact(gap0 = gap0,",
                "Gripper.Effects.HuntCrossleyContact contact(lambda_hc = lambda_hc, gap0 = gap0,"),),
        drive_parameters=("lambda_hc",),
        signature="impact peak and rebound: dissipation that grows with penetration",
    ),
    "gear_play": Effect(
        name="gear_play",
        title="gear play magnitude (frees the existing play parameter; no new equations)",
        parameters=(),
        frees=(("play", 0.0, 0.1),),
        signature="impact peak and the delay of first force after a reversal",
    ),
    "coating_relaxation": Effect(
        name="coating_relaxation",
        title="viscoelastic finger coating: a Maxwell branch k_rel*k_P with time constant tau_rel in parallel with "
              "the coating's elastic element (standard linear solid)",
        parameters=(EffectParameter("k_rel", 0.5, 0.0, 10.0, "1",
                                    "Maxwell branch stiffness per unit coating first-region stiffness"),
                    EffectParameter("tau_rel", 0.1, 0.02, 2.0, "s",
                                    "Coating relaxation time constant (slower than the impact, else it is damping)")),
        drive=(("Gripper.Components.FingerContact contact(gap0 = gap0,",
                "Gripper.Effects.RelaxingCoatingContact contact(k_rel = k_rel, tau_rel = tau_rel, gap0 = gap0,"),),
        drive_parameters=("k_rel", "tau_rel"),
        signature="coated fingers: the force held after the impact decays with tau_rel (bare fingers: no change)",
    ),
}


# The haptic device + user (Haptic.Device7 and the other Haptic.Device* models): blocks of Haptic.Effects wired in
# through the drive torque tau_1 on m1 and the user's torque tau_user on m2 (modelica/Haptic/package.mo).
_TAU_1 = "  equation\n    tau_1 = tau;"
EFFECTS.update({
    "hand_mass": Effect(
        name="hand_mass",
        title="the user's hand mass mh held by kh, bh behind the skin ks, bs (7 -> 11-parameter user, seed 000)",
        parameters=(EffectParameter("mh", 0.006, 1e-4, 0.1, "kg.m2", "Hand inertia at the phi axis"),
                    EffectParameter("kh", 3.0, 0.05, 100.0, "N.m/rad", "Stiffness of the hand to the user's reference",
                                    starts=(1.0, 10.0)),
                    EffectParameter("bh", 0.2, 1e-3, 3.0, "N.m.s/rad", "Damping of the hand to the user's reference"),
                    EffectParameter("b2", 0.02, 0.0, 0.5, "N.m.s/rad", "Viscous friction of m2 to ground")),
        top=((_TAU_1,
              "    Haptic.Effects.HandMass hand(mh = mh, kh = kh, bh = bh, ks = ks, bs = bs) \"Hand mass behind the "
              "skin\";\n" + _TAU_1),
             ("    tau_b2 = 0;\n    tau_user = -ks*(phi2 - phi_ref) - bs*w2 + tau_h;",
              "    tau_b2 = b2*w2;\n    hand.phi_s = phi2;\n    hand.w_s = w2;\n    hand.phi_ref = phi_ref;\n"
              "    hand.tau_h = tau_h;\n    tau_user = hand.tau;")),
        signature="below ~20 Hz: a second pole/zero pair (the hand's mode) the lumped m2 on ks, bs cannot shape",
    ),
    "vibration_mode": Effect(
        name="vibration_mode",
        title="a second device vibration mode: an inertia m3 hung on the motor-side inertia m1 by k3, b3",
        parameters=(EffectParameter("m3", 5e-4, 1e-5, 5e-3, "kg.m2", "Modal inertia of the second mode"),
                    EffectParameter("k3", 70.0, 1.0, 2000.0, "N.m/rad", "Modal stiffness of the second mode",
                                    starts=(12.0, 30.0, 160.0)),
                    EffectParameter("b3", 0.01, 1e-5, 0.5, "N.m.s/rad", "Modal damping of the second mode")),
        top=((_TAU_1,
              "    Haptic.Effects.SideMode mode(m3 = m3, k3 = k3, b3 = b3) \"Second vibration mode, hung on m1\";\n"
              "  equation\n    mode.phi = phi1;\n    mode.w = w1;\n    tau_1 = tau + mode.tau;"),),
        signature="a narrow antiresonance/resonance pair near sqrt(k3/m3), a phase wiggle there",
    ),
    "loop_delay": Effect(
        name="loop_delay",
        title="a pure delay T_d of the torque command (computation and amplifier), third-order Pade approximation",
        parameters=(EffectParameter("T_d", 1e-3, 1e-5, 5e-3, "s", "Delay of the torque command",
                                    starts=(0.3e-3, 3e-3)),),
        top=((_TAU_1,
              "    Haptic.Effects.PadeDelay delay(T = T_d) \"Loop delay of the torque command\";\n"
              "  equation\n    delay.u = tau;\n    tau_1 = delay.y;"),),
        signature="phase lag growing linearly with frequency (360 T_d deg/Hz), magnitude unchanged",
    ),
})


def effect_names():
    """Identifiers of the implemented effects, in library order."""
    return list(EFFECTS)


def applicable(source_text, model):
    """Identifiers of the implemented effects that apply to ``model`` of the Modelica ``source_text`` (their
    variant can be written), in library order."""
    names = []
    for name, effect in EFFECTS.items():
        try:
            variant_text(source_text, model, effect)
        except ConfigError:
            continue
        names.append(name)
    return names


def get_effect(name):
    """The :class:`Effect` called ``name``; a ConfigError lists the library when it is unknown."""
    if name in EFFECTS:
        return EFFECTS[name]
    raise ConfigError(f"unknown effect {name!r}; implemented: {', '.join(EFFECTS)}")


def _block(text, kind, name):
    match = re.search(rf"^( *){kind} {re.escape(name)}\b.*?^\1end {re.escape(name)};\n", text, re.S | re.M)
    if match is None:
        raise ConfigError(f"no `{kind} {name}` in the Modelica source")
    return match.group(0)


def _replace(text, old, new, effect, model):
    if old not in text:
        raise ConfigError(f"effect {effect.name!r} does not apply to {model}: its source has no `{old.strip()}`")
    return text.replace(old, new, 1)


def variant_text(source_text, model, effect):
    """The Modelica source of ``Pkg.Model`` with ``effect`` added: (variant model name, full package text).

    The variant (and the drivetrain copy it needs) go into a sub-package ``Diagnosis`` appended to the package."""
    package, _, short = model.rpartition(".")
    if not package or "." in package:
        raise ConfigError(f"model {model!r}: the diagnosis writes variants of top-level models Pkg.Model")
    base = _block(source_text, "model", short)
    tag = effect.name
    new_name = f"{short}_{tag}"
    top = base.replace(f"model {short} ", f"model {new_name} ", 1).replace(f"end {short};", f"end {new_name};")
    known = _known(source_text, base)
    blocks = []
    decls = "".join(
        f'    parameter Real {p.name}(unit = "{p.unit}") = {_default(p, known)} "{p.description} (effect {tag})";\n'
        for p in effect.parameters if not _exists(known, p.name))
    if effect.drive:
        drive = _block(source_text, "model", "DrivetrainMechanics")
        drive_name = f"DrivetrainMechanics_{tag}"
        drive = drive.replace("model DrivetrainMechanics ", f"model {drive_name} ", 1).replace(
            "end DrivetrainMechanics;", f"end {drive_name};")
        for old, new in effect.drive:
            drive = _replace(drive, old, new, effect, "Gripper.DrivetrainMechanics")
        drive_decls = "".join(
            f'    parameter Real {p.name}(unit = "{p.unit}") = {_default(p, known)} "{p.description} (effect {tag})";\n'
            for p in effect.parameters if p.name in effect.drive_parameters)
        drive = drive.replace("    extends Gripper.Parameters.DrivetrainParameters;\n",
                              "    extends Gripper.Parameters.DrivetrainParameters;\n" + drive_decls, 1)
        blocks.append(drive)
        passed = "".join(f"{n} = {n}, " for n in effect.drive_parameters)
        top = _replace(top, _DRIVE_ANCHOR, f"{package}.Diagnosis.{drive_name} drive({passed}", effect, model)
    for old, new in effect.top:
        top = _replace(top, old, new, effect, model)
    if decls:  # declared after the model's last `extends` line
        bases = re.findall(r"^    extends [^\n]*;\n", top, re.M)
        if not bases:
            raise ConfigError(f"effect {effect.name!r} does not apply to {model}: it has no `extends` line to "
                              f"declare the effect's parameters after")
        top = top.replace(bases[-1], bases[-1] + decls, 1)
    for name, _, _ in effect.frees:
        if not _exists(known, name):
            raise ConfigError(f"effect {effect.name!r} does not apply to {model}: it has no parameter {name!r}")
    blocks.append(top)
    body = "".join(_indent(b) for b in blocks)
    sub = (f'  package Diagnosis "Model variants written by cosim diagnose: the baseline plus one effect '
           f'(docs/diagnose.md)"\n{body}  end Diagnosis;\n')
    end = f"end {package};"
    if end not in source_text:
        raise ConfigError(f"the Modelica source does not end with `{end}`")
    head, _, tail = source_text.rpartition(end)
    return f"{package}.Diagnosis.{new_name}", head + sub + end + tail


def _known(source_text, base):
    """Where the baseline's parameters are declared: the model itself, the local models it extends (e.g.
    ``extends Device(...)``) and the package's shared ``package Parameters`` when it has one."""
    blocks = [base]
    for name in re.findall(r"^    extends (\w+)[ (;]", base, re.M):
        blocks.append(_block(source_text, "(?:partial )?model", name))
    if re.search(r"^  package Parameters\b", source_text, re.M):
        blocks.append(_block(source_text, "package", "Parameters"))
    return "".join(blocks)


def _exists(text, name):
    return re.search(rf"parameter Real {re.escape(name)}\(", text) is not None


def _default(p, known):
    """The declared default: the effect's start value, or the baseline default of the parameter it starts from."""
    if isinstance(p.start, (int, float)):
        return p.start
    match = re.search(rf"parameter Real {re.escape(p.start)}\([^)]*\) = ([-+0-9.eE]+)", known)
    if match is None:
        raise ConfigError(f"effect parameter {p.name} starts from {p.start!r}, which the baseline does not declare "
                          f"with a numeric default")
    return float(match.group(1))


def _indent(block):
    return "".join("  " + line if line.strip() else line for line in block.splitlines(keepends=True))


def write_variant(source, model, effect, folder):
    """Write the package with ``effect``'s variant of ``model`` to ``folder/<Pkg>/package.mo``.

    Returns (path of the written file, variant model name). The folder gets only this one package, as the
    compiler front end loads every ``.mo`` of a directory."""
    source = Path(source)
    name, text = variant_text(source.read_text(encoding="utf-8"), model, effect)
    out = Path(folder) / source.parent.name / source.name
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text, encoding="utf-8")
    return out, name
