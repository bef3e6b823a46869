"""Records with a known effect hidden in them, for testing ``studies discover``.

The effect's magnitude is drawn (seeded) from a physically sensible range;
the records are what a sensor would give (measured rudder, over-ground
velocities, the recorded wind), optionally with measurement noise of one of
the families of :mod:`studies.environment.sensor_noise` (by default Li et
al. 2023 eq. 22). Used by the tests and the hit-rate benchmark.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..environment.conditions import Environment
from ..environment.noise import DISTURBANCE_FACTORS
from ..environment.sensor_noise import add_sensor_noise, ar1_noise, check_sensor_noise
from ..errors import ConfigError
from ..models.abkowitz import abkowitz
from ..models.registry import symmetric
from ..models.terms import candidate_terms
from ..roll.simulate import simulate_decay_record
from ..simulate import simulate, turning, zigzag
from ..simulate.manoeuvres import Manoeuvre

__all__ = ["HIDDEN_CAUSES", "HIDDEN_ROLL_CAUSES", "HIDDEN_ROLL_SPEED_CAUSES", "Scenario", "draw_scenario",
           "hidden_records",
           "hidden_roll_decays", "hidden_roll_decays_at_speed", "hidden_roll_speed_series", "write_records",
           "parameters_match"]

HIDDEN_CAUSES = ("none", "current", "rudder_offset", "wind_speed_bias", "environmental_bias",
                 "missing_term", "wind_unmodelled", "propeller_asymmetry")


#: roll-decay causes: the damping term hidden and the centre of its drawn magnitude
HIDDEN_ROLL_CAUSES = {"roll_quadratic_damping": ("b2", 0.4), "roll_cubic_damping": ("b3", 0.8)}

#: roll-decay causes at forward speed that a potential-flow run misses: the centre of each
#: hidden parameter's drawn magnitude (b1_added [1/s] added to the run's b1, b2 [-])
HIDDEN_ROLL_SPEED_CAUSES = {"roll_linear_damping": {"b1_added": 0.04},
                            "roll_linear_damping+roll_quadratic_damping": {"b1_added": 0.04, "b2": 0.12}}

#: the potential-flow-like run of the hidden forward-speed decays: natural frequency [rad/s]
#: and the radiation damping [1/s] it does model
_SPEED_BASELINE = {"omega0": 2.5, "b1": 0.01}


def _draw(cause: str, rng) -> dict:
    sign = rng.choice([-1.0, 1.0])
    if cause == "current":
        return {"speed": rng.uniform(0.2, 0.8), "direction": rng.uniform(0, 2 * np.pi)}
    if cause == "rudder_offset":
        return {"delta0": sign * np.deg2rad(rng.uniform(1.0, 3.0))}
    if cause == "wind_speed_bias":
        return {"k": sign * rng.uniform(0.1, 0.3), "wind_speed": rng.uniform(12, 16),
                "wind_direction": rng.uniform(0, 2 * np.pi)}
    if cause == "environmental_bias":
        return {"bx": rng.choice([-1, 1]) * rng.uniform(1e-5, 3e-5),
                "by": rng.choice([-1, 1]) * rng.uniform(1e-5, 3e-5), "bn": 0.0}
    if cause == "missing_term":
        return {"Nrrr": -rng.uniform(0.002, 0.004)}
    if cause == "wind_unmodelled":
        return {"speed": rng.uniform(10, 16), "direction": rng.uniform(0, 2 * np.pi)}
    if cause == "propeller_asymmetry":
        # a side force worth 0.6-1.6 deg of the Mariner's rudder at the approach speed,
        # applied near the propeller (moment arm 0.35-0.55 L aft)
        yp = sign * rng.uniform(3e-5, 8e-5)
        return {"Yp0": yp, "Np0": -yp * rng.uniform(0.35, 0.55)}
    return {}


def turning_to_starboard(amplitude: float = 35.0, duration: float = 600.0, dt: float = 0.1) -> Manoeuvre:
    """A turning circle with the rudder to port (negative in the data contract: the heading
    increases, a turn to starboard), no pull-out, named ``turning_<a>_starboard``."""
    return Manoeuvre(f"turning_{amplitude:g}_starboard", "turning", duration, dt, amplitude=amplitude,
                     heading=0.0, first_sign=-1)


def _zigzag_to(amplitude: float, side: int, duration: float, dt: float) -> Manoeuvre:
    """A zig-zag ``amplitude/amplitude`` [deg], first rudder to ``side`` (+1: positive rudder, a
    turn to port for the Mariner), named ``zigzag_<a>_<a>`` (``..._port_first`` for the other side)."""
    name = f"zigzag_{amplitude:g}_{amplitude:g}" + ("" if side > 0 else "_port_first")
    return Manoeuvre(name, "zigzag", duration, dt, amplitude=amplitude, heading=amplitude, first_sign=side)


def _turning_to(amplitude: float, side: int, duration: float, dt: float) -> Manoeuvre:
    """A turning circle without pull-out, rudder ``amplitude`` [deg] to ``side`` (+1: positive
    rudder, the heading decreasing for the Mariner), named ``turning_<a>`` (``..._starboard``)."""
    if side > 0:
        return turning(amplitude, pullout=0.0, duration=duration, dt=dt)
    return Manoeuvre(f"turning_{amplitude:g}_starboard", "turning", duration, dt, amplitude=amplitude,
                     heading=0.0, first_sign=-1)


@dataclass(frozen=True)
class Scenario:
    """How the records of a hidden-effect case are made, besides the effect and the sensor noise.

    Attributes
    ----------
    dt : float
        Sampling interval of the records [s] (the simulation steps at most 0.1 s).
    duration : float
        Length of every record [s].
    train : tuple of (kind, amplitude [deg], side)
        Training manoeuvres: ``("zigzag", 20, 1)`` is a 20/20 zig-zag with the
        first rudder positive, ``("turning", 35, -1)`` a 35 deg turning circle
        with negative rudder (to starboard); see :func:`_zigzag_to`, :func:`_turning_to`.
    validate : tuple (kind, amplitude, side)
        The held-out manoeuvre.
    process : float
        Process noise: the standard deviation of a body-fixed force and moment
        that wander as Ornstein-Uhlenbeck processes (correlation time
        :data:`PROCESS_TIME` s), as a fraction of each DOF's largest clean
        prime force (times 0.2 in surge, as the SVM paper's eq. 14 factors);
        0: none. Waves, gusts and the model's own small errors act this way.
    """

    dt: float = 0.1
    duration: float = 600.0
    train: tuple = (("zigzag", 20.0, 1), ("turning", 35.0, 1))
    validate: tuple = ("zigzag", 10.0, 1)
    process: float = 0.0

    def manoeuvres(self) -> list[Manoeuvre]:
        """The training manoeuvres, then the held-out one."""
        make = {"zigzag": _zigzag_to, "turning": _turning_to}
        return [make[kind](float(a), int(side), float(self.duration), float(self.dt))
                for kind, a, side in (*self.train, self.validate)]


#: the development set-up of :func:`hidden_records` (and the tests'): a 20/20 zig-zag and a 35 deg
#: turning circle to train, a 10/10 zig-zag to validate, 600 s at 0.1 s, no process noise
FIXED_SCENARIO = Scenario()

#: correlation time of the scenario's process noise [s]
PROCESS_TIME = 10.0


def draw_scenario(seed: int, cause: str) -> Scenario:
    """A scenario drawn from its own seeded stream (independent of the effect's
    and the noise's draws, so the same seed hides the same effect under any
    scenario): sampling 0.1, 0.2 or 0.5 s; records of 400-900 s; training on a
    turning circle (25 or 35 deg, either side) and a zig-zag (10/10 or 20/20,
    either side first), validating on the other zig-zag or on a turning circle
    to the other side; process noise in half the cases, 1-3 % of each DOF's
    largest force. A propeller's side force (``propeller_asymmetry`` in
    ``cause``) trains on 35 deg turning circles to both sides (only they can
    show it) and validates on a zig-zag."""
    rng = np.random.default_rng([int(seed), 20261125])
    dt = float(rng.choice([0.1, 0.2, 0.5]))
    duration = float(10 * round(rng.uniform(400.0, 900.0) / 10))
    side = lambda: int(rng.choice([-1, 1]))                    # noqa: E731
    zig = float(rng.choice([10.0, 20.0]))
    turn = ("turning", float(rng.choice([25.0, 35.0])), side())
    train = (turn, ("zigzag", zig, side()))
    if rng.uniform() < 0.5:
        validate = ("zigzag", 30.0 - zig, side())
    else:
        validate = ("turning", 35.0 if turn[1] == 25.0 else 25.0, -turn[2])
    if "propeller_asymmetry" in cause.split("+"):
        train, validate = (("turning", 35.0, 1), ("turning", 35.0, -1)), ("zigzag", zig, side())
    process = float(rng.uniform(0.01, 0.03)) if rng.uniform() < 0.5 else 0.0
    return Scenario(dt, duration, train, validate, process)


def process_forces(n_steps: int, dt: float, force_scale: np.ndarray, level: float, rng) -> np.ndarray:
    """Body-fixed prime process noise (n_steps, 3): Ornstein-Uhlenbeck forces of
    correlation time :data:`PROCESS_TIME` and standard deviation ``level`` times
    ``force_scale`` (the largest clean prime force per DOF) times the SVM paper's
    factors (0.2 in surge)."""
    scale = np.asarray(force_scale, float) * DISTURBANCE_FACTORS * level
    return ar1_noise((n_steps, 3), dt, PROCESS_TIME, rng) * scale


#: pairs of hidden causes that cannot act together (both are the wind)
EXCLUSIVE = {frozenset({"wind_speed_bias", "wind_unmodelled"})}


def hidden_pairs() -> list[str]:
    """Every pair of :data:`HIDDEN_CAUSES` (not ``none``) that can act together, as ``"a+b"``."""
    single = [c for c in HIDDEN_CAUSES if c != "none"]
    return [f"{a}+{b}" for i, a in enumerate(single) for b in single[i + 1:]
            if frozenset({a, b}) not in EXCLUSIVE]


def _any_missing_term(vessel, model, values, rng, clean, dof: str | None = None) -> dict:
    """A term drawn from the extended library of ``model`` (up to third order;
    any DOF, or only ``dof``'s: ``"X"``, ``"Y"`` or ``"N"``), its prime value
    set so that it changes its DOF's hydrodynamic force by 5-15 % (RMS over
    the clean record ``clean``), with either sign."""
    from ..identification.regression import prime_states
    from ..discovery.causes.missing_term import extended_library

    primes = prime_states(clean["u"], clean["v"], clean["r"], clean["delta"], vessel)
    library = [t for t in extended_library(model, 3) if dof is None or t.dof == dof]
    term = library[int(rng.integers(len(library)))]
    force = sum(values[t.name] * t.feature(primes) for t in model.terms_of(term.dof))
    feature = term.feature(primes)
    scale = np.sqrt(np.mean(force ** 2)) / max(np.sqrt(np.mean(feature ** 2)), 1e-12)
    return {term.name: float(rng.choice([-1.0, 1.0]) * rng.uniform(0.05, 0.15) * scale)}


def hidden_records(vessel, cause: str, seed: int = 0, noise: float = 0.0,
                   manoeuvres=None, noise_family: str = "li2023",
                   missing: str = "Nrrr", scenario: Scenario | None = None) -> tuple[list, dict]:
    """Records of the vessel's reference model with ``cause`` hidden in them.

    Returns ``(records, truth)``: records named after their manoeuvre
    (default: zig-zag 20/20 and a 35 deg turning circle for training, then a
    zig-zag 10/10 to validate; 600 s each at 0.1 s; for ``propeller_asymmetry``
    35 deg turning circles to port and to starboard for training, the
    symmetric model's coefficients with the side force added: discover it
    with ``model=symmetric``) and the drawn parameters. ``noise`` is the
    level (a fraction, 0.05 = 5 %) of the measurement noise of
    ``noise_family`` (:data:`studies.environment.sensor_noise.NOISE_FAMILIES`),
    drawn from the same seeded generator after the cause's parameters.

    ``cause`` may be a pair ``"a+b"`` (:func:`hidden_pairs`): both act, drawn
    in that order, and ``truth`` is ``{a: {...}, b: {...}}``. ``missing``
    chooses the hidden term of ``missing_term``: ``"Nrrr"`` (a cubic yaw
    damping, the development case), ``"any"`` (:func:`_any_missing_term`:
    any term of the extended library, any DOF, 5-15 % of its DOF's force) or
    ``"X"``, ``"Y"``, ``"N"`` (the same, drawn from that DOF's terms).
    ``scenario`` (:class:`Scenario`, e.g. :func:`draw_scenario`) sets the
    manoeuvres, their length and sampling and the process noise instead
    (``manoeuvres`` must then be None); the process noise is drawn from
    the same generator after the sensor noise of each record.
    """
    check_sensor_noise(noise_family, noise)
    parts = cause.split("+")
    if len(parts) > 2 or any(p not in HIDDEN_CAUSES for p in parts) or (len(parts) == 2 and (
            "none" in parts or parts[0] == parts[1] or frozenset(parts) in EXCLUSIVE)):
        raise ConfigError(f"hidden cause {cause!r}: one of {', '.join(HIDDEN_CAUSES)} or a pair "
                          "of two others that can act together")
    if missing not in ("Nrrr", "any", "X", "Y", "N"):
        raise ConfigError(f"hidden missing term {missing!r}: 'Nrrr', 'any' or a DOF ('X', 'Y', 'N')")
    if scenario is not None and manoeuvres is not None:
        raise ConfigError("hidden records: give the manoeuvres or a scenario, not both")
    rng = np.random.default_rng(seed)
    model, values = abkowitz(), dict(vessel.coefficients)
    if "propeller_asymmetry" in parts:
        # the Mariner's own port-starboard terms (Y0 ... N0uu) replaced by the propeller's force:
        # discover it against the symmetric baseline (model=symmetric)
        model = symmetric()
        values = {t.name: values[t.name] for t in model.terms}
    if manoeuvres is None and "propeller_asymmetry" in parts:
        # an asymmetry shows in turns to both sides
        manoeuvres = [turning(35, pullout=0.0, duration=600.0), turning_to_starboard(35, duration=600.0),
                      zigzag(10, 10, duration=600.0)]
    if scenario is not None:
        manoeuvres = scenario.manoeuvres()
    manoeuvres = manoeuvres or [zigzag(20, 20, duration=600.0), turning(35, pullout=0.0, duration=600.0),
                                zigzag(10, 10, duration=600.0)]
    truths = {}
    for part in parts:
        if part == "missing_term" and missing != "Nrrr":
            clean = simulate(model, values, vessel, manoeuvres[0])
            truths[part] = _any_missing_term(vessel, model, values, rng, clean,
                                             None if missing == "any" else missing)
        else:
            truths[part] = _draw(part, rng)
    wind = current = (0.0, 0.0)
    body = np.zeros(9)
    for part, truth in truths.items():
        if part == "current":
            current = (truth["speed"], truth["direction"])
        elif part == "wind_speed_bias":
            wind = (truth["wind_speed"], truth["wind_direction"])
        elif part == "wind_unmodelled":
            wind = (truth["speed"], truth["direction"])
        elif part == "environmental_bias":
            body[:3] = [truth["bx"], truth["by"], truth["bn"]]
        elif part == "propeller_asymmetry":
            # a body-fixed force of constant magnitude (prime at the approach speed)
            body[7:] = [truth["Yp0"], truth["Np0"]]
        elif part == "missing_term":
            names = set(truth)
            model = model.extended([t for dof in ("X", "Y", "N") for t in candidate_terms(dof, 3)
                                    if t.name in names])
            values.update(truth)
    env = Environment(wind[0], wind[1], current[0], current[1])
    records = []
    process = [] if scenario is None or scenario.process <= 0 else \
        [_process_noise(model, values, vessel, man, env, scenario.process, rng) for man in manoeuvres]
    for i, man in enumerate(manoeuvres):
        n_steps = len(man.step_times()) - 1
        external = np.tile(body, (n_steps, 1)) if body.any() else None
        if process:
            external = np.zeros((n_steps, 9)) if external is None else external
            external[:, 3:6] += process[i]
        rec = simulate(model, values, vessel, man, env, external)
        if "rudder_offset" in truths:
            rec["delta"] = rec["delta"] + truths["rudder_offset"]["delta0"]
        if "wind_unmodelled" in truths:
            rec = rec.drop(columns=["wind_speed", "wind_direction"])
        if "wind_speed_bias" in truths:
            rec["wind_speed"] = rec["wind_speed"] * (1.0 + truths["wind_speed_bias"]["k"])
        rec = add_sensor_noise(rec, noise_family, noise, vessel.speed, rng)
        rec.attrs["name"] = man.name
        rec.attrs["vessel"] = vessel.name
        records.append(rec)
    return records, (truths[parts[0]] if len(parts) == 1 else truths)


def _process_noise(model, values, vessel, manoeuvre, env, level: float, rng) -> np.ndarray:
    """Process noise of :func:`process_forces` for one manoeuvre (one row per
    integration step), sized on the clean run's largest prime forces."""
    from ..identification.regression import prime_states

    clean = simulate(model, values, vessel, manoeuvre, env)
    primes = prime_states(clean["u"], clean["v"], clean["r"], clean["delta"], vessel)
    scale = np.max(np.abs(model.forces(primes, values)), axis=0)
    return process_forces(len(manoeuvre.step_times()) - 1, manoeuvre.step, scale, level, rng)


def hidden_roll_decays(cause: str, folder, seed: int = 0, noise: float = 0.01) -> tuple[list, dict]:
    """Two roll decays (released from 10 and 8 deg, 40 s at 0.01 s, omega0 2.5 rad/s,
    b1 0.05) with the damping term of ``cause`` hidden, its magnitude drawn within
    +-20 % of :data:`HIDDEN_ROLL_CAUSES`; ``noise`` is a fraction of the release
    angle. Written as CSV files in ``folder``; returns ``(paths, {term: value})``.
    """
    term, centre = HIDDEN_ROLL_CAUSES[cause]
    value = centre * np.random.default_rng(seed).uniform(0.8, 1.2)
    params = {"omega0": 2.5, "b1": 0.05, term: value}
    paths = []
    for i, phi0 in enumerate((10.0, 8.0)):
        path = Path(folder) / f"decay_{i}.csv"
        simulate_decay_record(params, ["b1", term], 40.0, 0.01, np.deg2rad(phi0), noise, seed * 10 + i, path)
        paths.append(str(path))
    return paths, {term: value}


def _decay_csv(params, terms, path, duration, phi0_deg, noise, seed, speed) -> str:
    """One simulated decay (0.01 s) with a ``speed`` column [m/s], written to ``path``."""
    rec = simulate_decay_record(params, terms, duration, 0.01, np.deg2rad(phi0_deg), noise, seed)
    rec["speed"] = float(speed)
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    rec.to_csv(path, index=False, float_format="%.10g")
    return str(path)


def hidden_roll_decays_at_speed(cause: str, folder, seed: int = 0, noise: float = 0.01, speed: float = 1.0,
                                records: int = 1, duration: float = 60.0) -> tuple[list, str, dict]:
    """Decays at forward speed with damping hidden that a potential-flow run misses.

    The run (``simulation.path``) is the linear model with omega0 2.5 rad/s and
    the radiation damping b1 0.01 1/s, released from 10 deg without noise;
    the measured decays (released from 10, 8, 12 deg, ``duration`` s at
    0.01 s, ``noise`` a fraction of the release angle, seeded) add the
    parameters of ``cause`` (:data:`HIDDEN_ROLL_SPEED_CAUSES`), each drawn
    within +-20 % of its centre. Every file has a ``speed`` column
    (``speed`` [m/s]). Returns ``(paths, simulation_path, truth)``.
    """
    rng = np.random.default_rng(seed)
    truth = {name: centre * rng.uniform(0.8, 1.2) for name, centre in HIDDEN_ROLL_SPEED_CAUSES[cause].items()}
    sim = _decay_csv(_SPEED_BASELINE, ["b1"], Path(folder) / "potential_flow.csv", duration, 10.0, 0.0, 0, speed)
    params = {"omega0": _SPEED_BASELINE["omega0"], "b1": _SPEED_BASELINE["b1"] + truth["b1_added"],
              "b2": truth.get("b2", 0.0)}
    paths = [_decay_csv(params, ["b1", "b2"], Path(folder) / f"decay_{i}.csv", duration, phi0, noise,
                        seed * 10 + i, speed)
             for i, phi0 in enumerate((10.0, 8.0, 12.0)[:records])]
    return paths, sim, truth


def hidden_roll_speed_series(folder, seed: int = 0, noise: float = 0.01, speeds=(0.0, 0.5, 1.0),
                             duration: float = 60.0) -> tuple[list, dict]:
    """One decay per speed [m/s] with ``b1 = b1_0 + b1_U U`` and a common ``b2``.

    ``b1_0`` (centre 0.02 1/s), ``b1_U`` (centre 0.04 1/m) and ``b2`` (centre
    0.1) are drawn within +-20 %; omega0 2.5 rad/s, released from 10 deg,
    ``duration`` s at 0.01 s with a ``speed`` column. Returns ``(paths, truth)``.
    """
    rng = np.random.default_rng(seed)
    truth = {"b1_0": 0.02 * rng.uniform(0.8, 1.2), "b1_U": 0.04 * rng.uniform(0.8, 1.2),
             "b2": 0.1 * rng.uniform(0.8, 1.2), "omega0": 2.5}
    paths = []
    for i, u in enumerate(speeds):
        params = {"omega0": 2.5, "b1": truth["b1_0"] + truth["b1_U"] * u, "b2": truth["b2"]}
        paths.append(_decay_csv(params, ["b1", "b2"], Path(folder) / f"decay_{u:g}ms.csv", duration, 10.0,
                                noise, seed * 10 + i, u))
    return paths, truth


def write_records(records, folder) -> list[str]:
    """Write records as CSV files named after them (what a user would hand over).

    A record whose ``attrs`` name its vessel gets a sidecar
    ``<name>.csv.yaml`` holding ``vessel: <name>`` (how a CSV says which
    ship it is, :mod:`studies.data.ships`).
    """
    paths = []
    for rec in records:
        path = Path(folder) / f"{rec.attrs['name']}.csv"
        rec.to_csv(path, index=False)
        if rec.attrs.get("vessel"):
            path.with_name(path.name + ".yaml").write_text(f"vessel: {rec.attrs['vessel']}\n")
        paths.append(str(path))
    return paths


def parameters_match(cause: str, parameters: dict, truth: dict, rel: float = 0.2,
                     angle: float = 0.2) -> bool:
    """Whether a discovery's parameters are within ``rel`` of the hidden ones
    (angles within ``angle`` rad; the horizontal bias as a vector). For a
    pair ``"a+b"``, ``parameters`` and ``truth`` hold both by cause id."""
    if "+" in cause and cause not in HIDDEN_ROLL_SPEED_CAUSES:
        return all(part in parameters and parameters_match(part, parameters[part], truth[part], rel, angle)
                   for part in cause.split("+"))
    def close(a, b):
        return abs(a - b) <= rel * abs(b)

    def near(a, b):
        return abs(np.angle(np.exp(1j * (a - b)))) <= angle

    p = parameters
    if cause in ("current", "wind_unmodelled"):
        return close(p["speed"], truth["speed"]) and near(p["direction"], truth["direction"])
    if cause == "rudder_offset":
        return close(p["delta0"], truth["delta0"])
    if cause == "propeller_asymmetry":
        return close(p["Yp0"], truth["Yp0"]) and close(p["Np0"], truth["Np0"])
    if cause == "wind_speed_bias":
        return close(p["k"], truth["k"])
    if cause == "environmental_bias":
        return bool(np.hypot(p["bx"] - truth["bx"], p["by"] - truth["by"])
                    <= rel * np.hypot(truth["bx"], truth["by"]))
    if cause == "missing_term":
        return all(name in p["terms"] and close(p["terms"][name], value) for name, value in truth.items())
    if cause in HIDDEN_ROLL_CAUSES:
        term = HIDDEN_ROLL_CAUSES[cause][0]
        return p.get(term) is not None and close(p[term], truth[term])
    if cause in HIDDEN_ROLL_SPEED_CAUSES:
        return all(p.get(name) is not None and close(p[name], truth[name]) for name in truth)
    return True
