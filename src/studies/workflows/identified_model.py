"""An identified manoeuvring model as a self-contained, simulable description.

What a ``studies run`` identified, with everything its simulator needs, so
that the model can be written to one JSON file (``identified_model.json`` in
the run directory, and inside the run's MLflow model) and simulated again
anywhere ``studies`` is installed, with the same results to the last bit:

- the model: its name and term set (coefficient name, DOF, exponents of
  ``(u', v', r', delta)`` and, for the MMG hull, the sign of the term);
- the identified coefficients (prime values);
- the vessel: every particular of :class:`~studies.vessels.base.Vessel` (the
  Abkowitz-type models) or :class:`~studies.vessels.kvlcc2_mmg.MMGVessel`
  (``model=mmg``, at the scale of the run, with the approach speed [m/s] and
  propeller rate [rps] the run simulated at), with the published
  coefficients the run compared against;
- for the MMG model, the propeller and rudder parameters the run used
  (published, or fitted by output error);
- the simulator's settings: the steady wind and current of the run's
  validation (speeds [m/s], directions [rad]), and the rudder servo
  (saturation [rad], rate [rad/s], time constant [s], in the vessel);
- the run's validation manoeuvres and their duration override [s].

:meth:`IdentifiedModel.predict` is what the MLflow model answers
(:mod:`studies.runtime.model_logging`). Its input is a table:

``manoeuvre`` (one row)
    a named manoeuvre of ``conf/manoeuvre/`` (``turning_35``,
    ``zigzag_20_20``, or the user's own), simulated from a straight run at
    the vessel's approach speed as a run's validation does; optional
    ``duration`` and ``dt`` [s] replace the manoeuvre's own;
``t``, ``rudder``
    a commanded rudder angle [rad] over time [s], passed through the
    vessel's steering gear (saturation, rate limit, servo lag) like a
    named manoeuvre's helm;
``t``, ``delta``
    the actual rudder angle [rad] prescribed (no steering gear), linear
    between samples, as a run replays a measured record.

Rudder angles follow the data contract: positive ``delta`` gives a negative
yaw moment and turns the ship to negative heading. For a time series the
first row's ``u`` [m/s], ``v`` [m/s], ``r`` [rad/s], ``x0``, ``y0`` [m],
``psi`` [rad], when given, are the initial state (default: straight ahead at
the approach speed, at the origin, heading north, rudder amidships). With
``delta``, a ``n`` column [rps] drives the MMG model's propeller (default:
the approach rate) and ``wind_speed`` [m/s] and ``wind_direction`` [rad,
where it comes from] columns give the others' wind (default: the model's
environment, which a named manoeuvre and a commanded rudder use). Output: the
simulated states in the data contract (``t, x0, y0, psi, u, v, r, delta``;
``n`` for the MMG model; ``wind_speed``, ``wind_direction`` in a wind),
sampled at the manoeuvre's ``dt`` or the series' median step from its first
time; rows after a divergence are NaN. Numbers are floats: MLflow's schema
check refuses 64-bit integer columns for its ``double`` (write ``400.0``).
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path

import numpy as np
import pandas as pd

from ..environment.conditions import Environment
from ..errors import ConfigError, DataError
from ..models.abkowitz import ManoeuvringModel, abkowitz
from ..models.mmg import MMGParameters, MMGTerm, mmg
from ..models.terms import Term
from ..simulate import Manoeuvre, replay, simulate
from ..simulate.mmg import replay_mmg, simulate_mmg
from ..vessels import get_mmg_vessel, get_vessel, has_mmg_particulars
from ..vessels.base import Vessel, WindParticulars
from ..vessels.kvlcc2_mmg import MMGVessel
from .settings import named_manoeuvre

__all__ = ["IdentifiedModel", "IDENTIFIED_MODEL_FILE", "FORMAT", "INPUT_COLUMNS", "OUTPUT_COLUMNS",
           "published_model"]

#: the file a run writes into its directory (and logs inside its MLflow model)
IDENTIFIED_MODEL_FILE = "identified_model.json"
#: ``format`` of that file; ``version`` says which layout
FORMAT = "studies.identified_model"
VERSION = 1

#: input columns of :meth:`IdentifiedModel.predict`: (name, type, unit and meaning)
INPUT_COLUMNS = (
    ("manoeuvre", "string", "a named manoeuvre (conf/manoeuvre/<name>.yaml), one row"),
    ("duration", "double", "[s] length of the named manoeuvre (default: its own)"),
    ("dt", "double", "[s] sampling step of the named manoeuvre (default: its own)"),
    ("t", "double", "[s] time of a rudder time series"),
    ("rudder", "double", "[rad] commanded rudder angle (through the steering gear)"),
    ("delta", "double", "[rad] actual rudder angle, prescribed"),
    ("u", "double", "[m/s] initial surge velocity (first row)"),
    ("v", "double", "[m/s] initial sway velocity (first row)"),
    ("r", "double", "[rad/s] initial yaw rate (first row)"),
    ("x0", "double", "[m] initial position north (first row)"),
    ("y0", "double", "[m] initial position east (first row)"),
    ("psi", "double", "[rad] initial heading (first row)"),
    ("n", "double", "[rps] propeller rate (MMG model)"),
    ("wind_speed", "double", "[m/s] true wind speed"),
    ("wind_direction", "double", "[rad] direction the wind comes from"),
)
#: output columns (data contract); the optional ones last
OUTPUT_COLUMNS = ("t", "x0", "y0", "psi", "u", "v", "r", "delta")
OPTIONAL_OUTPUT_COLUMNS = ("n", "wind_speed", "wind_direction")

_STATE_KEYS = ("u", "v", "r", "x0", "y0", "psi")
#: a rudder angle above this [rad] (80 deg) is taken for degrees
_MAX_RUDDER = math.radians(80.0)
_WHERE = "model input"


@dataclass(frozen=True)
class IdentifiedModel:
    """A manoeuvring model with its coefficients, vessel and simulator settings.

    Attributes
    ----------
    model : ManoeuvringModel
        The term set (``abkowitz``, ``symmetric``, ``simplified``, ``mmg``, ...).
    values : dict
        Prime coefficients ``{name: value}`` of every term.
    vessel : Vessel or MMGVessel
        The particulars the run simulated with (an :class:`MMGVessel` selects
        the MMG simulator).
    environment : Environment
        Steady wind and current of the simulations (the run's validation
        environment; the MMG simulator is calm-water only).
    modules : MMGParameters or None
        Propeller and rudder parameters of the MMG model (None: the vessel's).
    validation : tuple of str
        The run's validation manoeuvres (names of ``conf/manoeuvre/``).
    validation_duration : float or None
        The run's ``validate.duration`` [s] (None: each manoeuvre's own).
    source : dict
        What produced it (method, vessel and data of the run), for people.
    """

    model: ManoeuvringModel
    values: dict
    vessel: object
    environment: Environment = field(default_factory=Environment)
    modules: MMGParameters | None = None
    validation: tuple = ()
    validation_duration: float | None = None
    source: dict = field(default_factory=dict)

    @property
    def is_mmg(self) -> bool:
        """Whether the MMG simulator runs it (an :class:`MMGVessel`)."""
        return isinstance(self.vessel, MMGVessel)

    # ------------------------------------------------------------ simulation

    def simulate(self, manoeuvre: Manoeuvre, initial: dict | None = None) -> pd.DataFrame:
        """``manoeuvre`` simulated as a run's validation does (see :func:`studies.simulate.simulate`)."""
        if self.is_mmg:
            return simulate_mmg(self.model, self.values, self.vessel, manoeuvre, self.modules,
                                initial=initial)
        return simulate(self.model, self.values, self.vessel, manoeuvre, self.environment,
                        initial=initial)

    def replay(self, record: pd.DataFrame) -> pd.DataFrame:
        """A record's rudder (and propeller rate) replayed from its first state,
        as a run replays its validation records."""
        if self.is_mmg:
            rps = None if "n" in record else self.vessel.rps
            return replay_mmg(self.model, self.values, self.vessel, record, self.modules, rps)
        has_wind = "wind_speed" in record and "wind_direction" in record
        return replay(self.model, self.values, self.vessel, record,
                      None if has_wind else self.environment)

    def reference(self) -> "IdentifiedModel | None":
        """The model the run compared against: the vessel's published
        coefficients (the full Abkowitz model; the MMG hull with the vessel's
        propeller and rudder parameters), in the same environment. None when
        the vessel has none."""
        published = dict(self.vessel.coefficients or {})
        if self.is_mmg:
            standard = mmg(self.model.name)         # the published hull is the standard method's
            if not all(n in published for n in standard.names):
                return None
            return replace(self, model=standard, values={n: published[n] for n in standard.names},
                           modules=None, source={"model": "published"})
        full = abkowitz()
        if not all(n in published for n in full.names):
            return None
        return replace(self, model=full, values={n: published[n] for n in full.names},
                       source={"model": "published"})

    def predict(self, frame: pd.DataFrame) -> pd.DataFrame:
        """The simulated states for an input table (module docstring).

        Raises :class:`~studies.errors.ConfigError` for an unknown manoeuvre
        and :class:`~studies.errors.DataError` (naming the column and row)
        for a time series that cannot be simulated.
        """
        if not isinstance(frame, pd.DataFrame):
            frame = pd.DataFrame(frame)
        if "manoeuvre" in frame and frame["manoeuvre"].notna().any():
            return self._predict_named(frame)
        if "t" not in frame or not ({"rudder", "delta"} & set(frame.columns)):
            raise DataError(_WHERE, "give a column 'manoeuvre' (a named manoeuvre, e.g. turning_35) "
                            "or a time series: 't' [s] with 'rudder' (commanded) or 'delta' "
                            "(actual rudder angle) [rad]")
        if "rudder" in frame and "delta" in frame:
            raise DataError(_WHERE, "give either 'rudder' (commanded, through the steering gear) or "
                            "'delta' (actual rudder angle, prescribed), not both")
        column = "rudder" if "rudder" in frame else "delta"
        t = _finite(frame, "t")
        angle = _finite(frame, column)
        if len(t) < 2:
            raise DataError(_WHERE, "a time series needs at least 2 samples", "t")
        back = np.flatnonzero(np.diff(t) <= 0)
        if len(back):
            raise DataError(_WHERE, "time must increase strictly", "t", int(back[0] + 1))
        wild = np.flatnonzero(np.abs(angle) > _MAX_RUDDER)
        if len(wild):
            raise DataError(_WHERE, f"rudder angle {angle[wild[0]]:g} rad is beyond 80 deg: give "
                            "radians, not degrees", column, int(wild[0]))
        initial = {k: float(frame[k].iloc[0]) for k in _STATE_KEYS
                   if k in frame and np.isfinite(frame[k].iloc[0])}
        if column == "rudder":
            return self._predict_commanded(t, angle, initial)
        return self._predict_prescribed(frame, t, angle, initial)

    def _predict_named(self, frame: pd.DataFrame) -> pd.DataFrame:
        names = frame["manoeuvre"].dropna()
        if len(names) != 1:
            raise DataError(_WHERE, f"one named manoeuvre per call, got {len(names)} rows", "manoeuvre")
        row = frame.loc[names.index[0]]
        overrides = {}
        for key in ("duration", "dt"):
            if key in frame and pd.notna(row[key]):
                overrides[key] = float(row[key])
        return _plain(self.simulate(named_manoeuvre(str(names.iloc[0]), overrides)))

    def _predict_commanded(self, t, angle, initial: dict) -> pd.DataFrame:
        dt = float(np.median(np.diff(t)))
        series = tuple(zip((t - t[0]).tolist(), np.rad2deg(angle).tolist()))
        man = Manoeuvre("rudder", "rudder", float(t[-1] - t[0]), dt, series=series)
        out = self.simulate(man, initial or None)
        out["t"] = out["t"] + t[0]
        return _plain(out)

    def _predict_prescribed(self, frame: pd.DataFrame, t, angle, initial: dict) -> pd.DataFrame:
        start = {"u": float(self.vessel.speed), "v": 0.0, "r": 0.0, "x0": 0.0, "y0": 0.0, "psi": 0.0}
        start.update(initial)
        record = pd.DataFrame({"t": t, "delta": angle, **{k: np.full(len(t), v) for k, v in start.items()}})
        extra = ["n"] if self.is_mmg else ["wind_speed", "wind_direction"]
        for col in extra:
            if col in frame:
                record[col] = _finite(frame, col)
        if not self.is_mmg and ("wind_speed" in record) != ("wind_direction" in record):
            raise DataError(_WHERE, "a wind needs both 'wind_speed' [m/s] and 'wind_direction' [rad]",
                            "wind_speed" if "wind_speed" not in record else "wind_direction")
        record.attrs["name"] = "rudder"
        return _plain(self.replay(record))

    # ------------------------------------------------------------ the file

    def to_dict(self) -> dict:
        """Plain JSON-able content (floats exact through JSON)."""
        terms = [[t.name, t.dof, list(t.powers)] + ([t.sign, t.thrust, t.crossflow] if isinstance(t, MMGTerm) else [])
                 for t in self.model.terms]
        vessel = asdict(self.vessel)
        if self.is_mmg:
            vessel["captive"] = ""                 # a path on the machine that ran it
        return {
            "format": FORMAT, "version": VERSION,
            "simulator": "mmg" if self.is_mmg else "abkowitz",
            "model": {"name": self.model.name, "terms": terms},
            "coefficients": {n: float(self.values[n]) for n in self.model.names},
            "vessel": _jsonable(vessel),
            "modules": None if self.modules is None else _jsonable(asdict(self.modules)),
            "environment": _jsonable(asdict(self.environment)),
            "validation": {"manoeuvres": list(self.validation), "duration": self.validation_duration},
            "source": _jsonable(dict(self.source)),
        }

    @classmethod
    def from_dict(cls, body: dict) -> "IdentifiedModel":
        """The model a :meth:`to_dict` content describes; ``ConfigError`` when it is not one."""
        if not isinstance(body, dict) or body.get("format") != FORMAT:
            raise ConfigError(f"not an identified model of studies (no 'format': '{FORMAT}')")
        if body.get("version") != VERSION:
            raise ConfigError(f"identified model version {body.get('version')!r} is not known to this "
                              f"studies (knows {VERSION})")
        try:
            mmg_simulator = body["simulator"] == "mmg"
            terms = tuple(MMGTerm(n, d, tuple(p), float(rest[0]), int(rest[1]) if len(rest) > 1 else 0,
                                  bool(rest[2]) if len(rest) > 2 else False)
                          if mmg_simulator
                          else Term(n, d, tuple(p)) for n, d, p, *rest in body["model"]["terms"])
            model = ManoeuvringModel(str(body["model"]["name"]), terms)
            values = {n: float(body["coefficients"][n]) for n in model.names}
            vessel = _vessel(body["vessel"], mmg_simulator)
            modules = MMGParameters(**body["modules"]) if body.get("modules") else None
            environment = Environment(**body.get("environment") or {})
            validation = body.get("validation") or {}
            duration = validation.get("duration")
        except (KeyError, TypeError, ValueError) as error:
            raise ConfigError(f"identified model: missing or bad entry ({error})") from None
        return cls(model, values, vessel, environment, modules,
                   tuple(str(n) for n in validation.get("manoeuvres") or ()),
                   None if duration is None else float(duration), dict(body.get("source") or {}))

    def write(self, path: str | Path) -> Path:
        """Write :meth:`to_dict` as JSON to ``path``; the path."""
        path = Path(path)
        path.write_text(json.dumps(self.to_dict(), indent=1))
        return path

    @classmethod
    def read(cls, path: str | Path) -> "IdentifiedModel":
        """The model of a file written by :meth:`write`."""
        try:
            body = json.loads(Path(path).read_text())
        except (OSError, ValueError) as error:
            raise ConfigError(f"{path}: not a readable identified model ({error})") from None
        return cls.from_dict(body)


def published_model(vessel_name: str) -> IdentifiedModel:
    """The published model of a vessel: its Abkowitz coefficients (Mariner)
    or, for a vessel with MMG particulars and no Abkowitz coefficients
    (KVLCC2), its MMG model at model scale; calm water."""
    vessel = get_vessel(vessel_name)
    if vessel.coefficients:
        full = abkowitz()
        return IdentifiedModel(full, {n: vessel.coefficients[n] for n in full.names}, vessel,
                               source={"model": "published", "vessel": vessel_name})
    if has_mmg_particulars(vessel_name):
        particulars = get_mmg_vessel(vessel_name)
        hull = mmg()
        return IdentifiedModel(hull, {n: particulars.coefficients[n] for n in hull.names}, particulars,
                               source={"model": "published", "vessel": vessel_name})
    raise ConfigError(f"vessel '{vessel_name}' has no published coefficients to simulate; "
                      "give model_uri= (a model logged by studies run)")


def _vessel(body: dict, mmg_simulator: bool):
    body = dict(body)
    if mmg_simulator:
        body["modules"] = MMGParameters(**body.get("modules") or {})
        body["kt"] = tuple(body["kt"])
        known = {f.name for f in fields(MMGVessel)}
        return MMGVessel(**{k: v for k, v in body.items() if k in known})
    if body.get("wind") is not None:
        body["wind"] = WindParticulars(**body["wind"])
    known = {f.name for f in fields(Vessel)}
    return Vessel(**{k: v for k, v in body.items() if k in known})


def _jsonable(value):
    """Nested dicts/lists/tuples of numbers and strings as JSON types (floats kept exact)."""
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, (bool, str)) or value is None:
        return value
    if isinstance(value, (int, np.integer)):
        return int(value)
    return float(value)


def _finite(frame: pd.DataFrame, column: str) -> np.ndarray:
    try:
        values = pd.to_numeric(frame[column], errors="raise").to_numpy(float)
    except (TypeError, ValueError):
        raise DataError(_WHERE, "values must be numbers", column) from None
    bad = np.flatnonzero(~np.isfinite(values))
    if len(bad):
        raise DataError(_WHERE, "value is not a finite number", column, int(bad[0]))
    return values


def _plain(record: pd.DataFrame) -> pd.DataFrame:
    """The simulated record with the output columns in their order (attrs kept)."""
    columns = [c for c in OUTPUT_COLUMNS + OPTIONAL_OUTPUT_COLUMNS if c in record]
    out = record[columns]
    out.attrs = dict(record.attrs)
    return out
