"""Parameter rows of the haptic device + user models, read from the tables shipped in ``cosim/data``.

Seed 000 (Puerto et al. 2012, Table I): PHANToM Premium 1.0 phi axis held by 13 users at 6 grasp
positions, rotational parameters at the phi axis. Seed 001 (Fu & Cavusoglu, Tables I, II, IV): the
five-parameter human arm model, linear parameters at the stylus gimbal, and its uncertainty weights.
All values are returned in SI units. See ``cosim/data/README.md`` for provenance.
"""

from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
import math

import numpy as np
import pandas as pd

from cosim.errors import HapticDataError

__all__ = [
    "USERS",
    "POSITIONS",
    "R_POINT_A",
    "PARAMS_11",
    "PARAMS_7",
    "HapticParams",
    "ArmParams",
    "UncertaintyWeight",
    "load_user_params",
    "user_params_table",
    "load_arm_params",
    "load_uncertainty_weight",
]

USERS = tuple(range(1, 14))
POSITIONS = tuple(range(1, 7))
R_POINT_A = 0.17
"""Distance from the phi axis to point A (gimbal centre), m (seed 000 Sec. II-A)."""

PARAMS_11 = ("m1", "b1", "bc", "kc", "m2", "b2", "bs", "ks", "mh", "bh", "kh")
PARAMS_7 = ("m1", "b1", "bc", "kc", "m2", "bs", "ks")

# name -> (CSV column, factor to SI, SI unit)
_COLUMNS = {
    "m1": ("m1_kg_m2", 1.0, "kg.m2"),
    "b1": ("b1_Nms_per_rad", 1.0, "N.m.s/rad"),
    "bc": ("bc_Nms_per_rad", 1.0, "N.m.s/rad"),
    "kc": ("kc_Nm_per_rad", 1.0, "N.m/rad"),
    "m2": ("m2_kg_m2", 1.0, "kg.m2"),
    "b2": ("b2_Nms_per_rad", 1.0, "N.m.s/rad"),
    "bs": ("bs_Nms_per_rad", 1.0, "N.m.s/rad"),
    "ks": ("ks_Nm_per_rad", 1.0, "N.m/rad"),
    "mh": ("mh_kg_m2", 1.0, "kg.m2"),
    "bh": ("bh_Nms_per_rad", 1.0, "N.m.s/rad"),
    "kh": ("kh_Nm_per_rad", 1.0, "N.m/rad"),
}
# Table I prints values below 0.001 (in table units) as 0; the table unit of masses is g.m2.
_TABLE_UNIT_TO_SI = {"m1": 1e-3, "m2": 1e-3, "mh": 1e-3}


@dataclass(frozen=True)
class HapticParams:
    """One user x grasp-position row of seed 000 Table I, in SI units at the phi axis.

    Attributes
    ----------
    user : int
        User number, 1..13.
    position : int
        Grasp position, 1 (stylus tip) .. 6 (far end).
    structure : int
        11 or 7: the model the values are for (eq. 2 or eq. 9).
    values : dict of str to float
        Parameter values: masses in kg.m2, dampings in N.m.s/rad, stiffnesses in N.m/rad. Keys are
        ``PARAMS_11`` or ``PARAMS_7``.
    paper_structure : int
        The structure the paper fitted this row with.
    kind : str
        ``paper`` (user 1) or ``derived`` (users 2-13: placement of the 11-parameter hand values inferred,
        see cosim/data/README.md).
    """

    user: int
    position: int
    structure: int
    values: dict
    paper_structure: int
    kind: str

    def __getitem__(self, name):
        return self.values[name]

    def to_linear(self, r=R_POINT_A):
        """Return the values converted to linear units at point A (divide by r**2): kg, N.s/m, N/m."""
        return {k: v / r**2 for k, v in self.values.items()}


@dataclass(frozen=True)
class ArmParams:
    """Five-parameter arm model of seed 001 (linear, at the stylus gimbal centre).

    Attributes
    ----------
    axis : str
        ``X``, ``Y`` or ``Z``.
    grip : str
        ``1``, ``2``, ``3`` (grip force in N, Table I) or ``nominal`` (Table II).
    M : float
        Arm mass, kg.
    k1, b1 : float
        Grasp stiffness N/m and damping N.s/m (stylus point to M).
    k2, b2 : float
        Arm stiffness N/m and damping N.s/m (M to ground).
    """

    axis: str
    grip: str
    M: float
    k1: float
    k2: float
    b1: float
    b2: float

    def to_rotational(self, r=R_POINT_A):
        """Return the equivalent phi-axis parameters (multiply by r**2) under the 11-parameter names.

        The Fu arm attached at point A is the 11-parameter user with ks, bs = k1, b1 and mh, kh, bh = M,
        k2, b2 (the mapping seed 001 Sec. IV-A uses for Diaz's model).
        """
        r2 = r**2
        return {"ks": self.k1 * r2, "bs": self.b1 * r2, "mh": self.M * r2, "kh": self.k2 * r2, "bh": self.b2 * r2}


@dataclass(frozen=True)
class UncertaintyWeight:
    """Multiplicative uncertainty weight V(s) = K prod(s - z_i) / prod(s - p_i) of seed 001 eq. (5), Table IV.

    Attributes
    ----------
    axis : str
    level : str
        ``max`` or ``67ci``.
    K : float
    zeros, poles : numpy.ndarray of complex
        Roots in rad/s (each printed pair gives re +- j im).
    garbled : bool
        True when a printed value of this weight is known to be damaged by the text extraction.
    """

    axis: str
    level: str
    K: float
    zeros: np.ndarray
    poles: np.ndarray
    garbled: bool


def _read_csv(name):
    with resources.files("cosim").joinpath("data", name).open("r", encoding="utf-8") as fh:
        return pd.read_csv(fh, dtype=str, keep_default_na=False)


@lru_cache(maxsize=None)
def _phantom_table():
    return _read_csv("phantom_user_params.csv")


def _check_choice(name, value, allowed):
    try:
        ok = value in allowed
    except TypeError:
        ok = False
    if isinstance(value, bool) or not ok:
        raise HapticDataError(f"unknown {name} {value!r}; expected one of {list(allowed)}")


def _is_number(value):
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)


def load_user_params(user, position, structure=None, zero_as=None):
    """Return one user x grasp-position parameter row of seed 000 Table I in SI units.

    Parameters
    ----------
    user : int
        1..13.
    position : int
        1..6.
    structure : {None, 11, 7}, optional
        The model structure the values are wanted for. None (default) uses the structure the paper fitted
        the row with. Asking for 11 on a row fitted with the 7-parameter model raises, because b2, mh, bh
        and kh do not exist for it. Asking for 7 on an 11-parameter row returns the seven shared values
        (their meaning differs: the hand is not lumped into m2; use with care).
    zero_as : float, optional
        Table I prints values below 0.001 (table units) as 0. None (default) keeps 0. A number in [0, 0.001)
        replaces each printed 0 by that value in table units (g.m2 for masses), e.g. to avoid a zero mass in
        a simulation.

    Returns
    -------
    HapticParams

    Raises
    ------
    HapticDataError
        Unknown user, position or structure, or the row lacks a value the structure needs.
    """
    _check_choice("user", user, USERS)
    _check_choice("position", position, POSITIONS)
    if structure is not None:
        _check_choice("structure", structure, (7, 11))
    if zero_as is not None and not (_is_number(zero_as) and 0.0 <= zero_as < 1e-3):
        raise HapticDataError(f"zero_as must be a number in [0, 0.001) table units; got {zero_as!r}")
    table = _phantom_table()
    rows = table[(table["user"] == str(user)) & (table["position"] == str(position))]
    if len(rows) != 1:
        raise HapticDataError(f"phantom_user_params.csv: expected one row for user {user} position {position}, found {len(rows)}")
    return _row_to_params(rows.iloc[0], structure, zero_as, user, position)


def _row_to_params(row, structure, zero_as, user, position):
    paper_structure = int(row["model_params"])
    structure = paper_structure if structure is None else structure
    names = PARAMS_11 if structure == 11 else PARAMS_7
    values = {}
    missing = []
    for name in names:
        col, factor, _ = _COLUMNS[name]
        text = row[col].strip()
        if text == "":
            missing.append(name)
            continue
        try:
            v = float(text) * factor
        except ValueError as err:
            raise HapticDataError(f"user {user} position {position}: column {col} holds {text!r}, not a number") from err
        if not math.isfinite(v) or v < 0:
            raise HapticDataError(f"user {user} position {position}: column {col} = {text!r} must be finite and >= 0")
        if v == 0.0 and zero_as is not None:
            v = float(zero_as) * _TABLE_UNIT_TO_SI.get(name, 1.0)
        values[name] = v
    if missing:
        raise HapticDataError(
            f"user {user} position {position}: the {structure}-parameter structure needs {', '.join(missing)}, "
            f"which the row does not have (the paper fitted it with the {paper_structure}-parameter model)"
        )
    kind = "paper" if row["kind_hand"] in ("paper", "") and row["model_assignment_kind"] == "paper" else "derived"
    return HapticParams(user, position, structure, values, paper_structure, kind)


def user_params_table(zero_as=None):
    """Return all 78 rows (13 users x 6 positions) in SI units, each with the paper's structure.

    Parameters
    ----------
    zero_as : float, optional
        As in `load_user_params`.

    Returns
    -------
    list of HapticParams
        Ordered by user, then position.
    """
    return [load_user_params(u, p, zero_as=zero_as) for u in USERS for p in POSITIONS]


@lru_cache(maxsize=None)
def _arm_table():
    return _read_csv("arm_models.csv")


def load_arm_params(axis, grip="nominal"):
    """Return a five-parameter arm model of seed 001 (Table I grip-force models or Table II nominal).

    Parameters
    ----------
    axis : {"X", "Y", "Z"}
    grip : {"nominal", 1, 2, 3}, optional
        Grip force in N (Table I), or ``"nominal"`` (Table II, default).

    Returns
    -------
    ArmParams

    Raises
    ------
    HapticDataError
        Unknown axis or grip.
    """
    _check_choice("axis", axis, ("X", "Y", "Z"))
    _check_choice("grip", str(grip), ("nominal", "1", "2", "3"))
    t = _arm_table()
    rows = t[(t["axis"] == axis) & (t["grip_force_N"] == str(grip))]
    if len(rows) != 1:
        raise HapticDataError(f"arm_models.csv: expected one row for axis {axis} grip {grip}, found {len(rows)}")
    r = rows.iloc[0]
    return ArmParams(
        axis, str(grip), float(r["M_kg"]), float(r["k1_N_per_m"]), float(r["k2_N_per_m"]),
        float(r["b1_Ns_per_m"]), float(r["b2_Ns_per_m"]),
    )


def load_uncertainty_weight(axis, level="max"):
    """Return a multiplicative uncertainty weight of seed 001 Table IV.

    Parameters
    ----------
    axis : {"X", "Y", "Z"}
    level : {"max", "67ci"}, optional
        Maximum observed variability (default) or the 67 % confidence-interval limit.

    Returns
    -------
    UncertaintyWeight
        ``garbled`` is True for Z/67ci, whose printed pole pair 5 (``-8.002 +- 05.687i``) is damaged in
        the extraction; it is used as printed (5.687).
    """
    _check_choice("axis", axis, ("X", "Y", "Z"))
    _check_choice("level", level, ("max", "67ci"))
    t = _read_csv("arm_uncertainty_weights.csv")
    rows = t[(t["axis"] == axis) & (t["level"] == level)]
    zeros, poles = [], []
    garbled = False
    for _, r in rows.iterrows():
        for kind, acc in (("zero", zeros), ("pole", poles)):
            re, im = float(r[f"{kind}_real_rad_per_s"]), float(r[f"{kind}_imag_rad_per_s"])
            acc.extend([complex(re, im), complex(re, -im)])
        garbled = garbled or "GARBLED" in r["note"]
    return UncertaintyWeight(axis, level, float(rows.iloc[0]["K"]), np.array(zeros), np.array(poles), garbled)
